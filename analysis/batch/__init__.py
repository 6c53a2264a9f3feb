"""Many scenes at once: batches (local workers or Dask), parameter studies, benchmarks."""
