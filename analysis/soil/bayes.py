"""Bayesian calibration of a soil's micro-parameters against its bench tests' targets, with GrainLearning's
iterative Bayesian filter (PyPI `grainlearning`, made for YADE models of granular materials). No YADE here: the
model is any function from a parameter vector to the bench responses (the cone index, c and φ of the shear box,
...), and the targets are the soil's measured values, never a hole's.

Each target is a range, its stated uncertainty (lo, hi). GrainLearning reads the responses as one observable's
sequence of "steps", one per response, each in units of its target's width: the k-th as k + 1 + (value - lo) /
(hi - lo), so its target's middle reads k + 1.5 (distinct middles: GrainLearning's error divides by their spread),
under one covariance for every step (`scale_cov_with_max`). A miss so weighs by how many of its own ranges it is (a
response whose target is small but wide, sand's c of 0-12 kPa, weighs no more than a narrow one); the posterior
after the last step holds them all.

The filter picks its likelihood's spread each iteration so that a set share of the samples keeps weight
(`seed_ess`); as the samples close in, that spread shrinks below what one run can resolve, and a sample whose one
packing happened to read inside takes all the weight. `scatter` ({response: SD over packings, in the response's
units}) puts a floor under it: the likelihood's SD never falls below the runs' packing scatter (the RMS over the
responses, each in units of its target's range), so two samples that differ by less than a packing's worth share
the weight.
"""
from __future__ import annotations

import numpy as np

HOLE_METRICS = {"L0", "L1", "L2", "L2_surface", "h1", "C", "pass_rate"}   # never a soil's target


MIDDLE = 1.5            # a target's middle in units of its range: 1 + (value - lo) / (hi - lo)


def in_ranges(value, target) -> float:
    """A response in units of its target's range (lo, hi): the range's middle reads 1.5. A response the model could
    not give (NaN: its test stopped, or the test after it never ran) reads as a miss a thousand ranges off, so its
    sample weighs nothing and the filter carries on.

    >>> in_ranges(6.0, (0.0, 12.0)), in_ranges(38.0, (28.0, 38.0)), in_ranges(float("nan"), (20.0, 35.0))
    (1.5, 2.0, 1000.0)
    """
    value, (lo, hi) = float(value), map(float, target)
    return 1.0 + (value - lo) / (hi - lo) if np.isfinite(value) else 1000.0


def largest_step(targets: dict) -> float:
    """The largest observation the filter sees for these targets (the last response's range middle): GrainLearning
    scales its likelihood's covariance with it (`scale_cov_with_max`), so its SD is sqrt(sigma) times this.

    >>> largest_step({"c": (0, 12), "phi": (26, 36), "slope": (28, 38)})
    3.5
    """
    return MIDDLE + len(targets) - 1


def sigma_floor(targets: dict, scatter: dict) -> float:
    """GrainLearning's lowest sigma for targets {response: (lo, hi)} whose runs scatter by `scatter` {response: SD}
    over packings: its likelihood's SD (sqrt(sigma) times the largest step, `scale_cov_with_max`) is then the RMS of
    the scatters in units of their ranges.

    >>> round(sigma_floor({"c": (0.0, 10.0), "phi": (20.0, 30.0)}, {"c": 2.5, "phi": 2.5}), 6)  # SD 0.25, step 2.5
    0.01
    """
    missing = sorted(set(targets) - set(scatter))
    bad = sorted(r for r in targets if r in scatter and not float(scatter[r]) > 0)
    if missing or bad:
        raise ValueError(f"calibrate: scatter of {(missing or bad)[0]}: allowed an SD above 0 for every target "
                         f"({', '.join(targets)})")
    sd = np.sqrt(np.mean([(float(scatter[r]) / (float(hi) - float(lo))) ** 2 for r, (lo, hi) in targets.items()]))
    return float((sd / largest_step(targets)) ** 2)


def first_samples(bounds: dict, samples: int, seed: int = 0) -> np.ndarray:
    """The filter's first iteration: a Latin hypercube over `bounds` ({name: (lo, hi)}, one column each), its
    centred discrepancy optimised (scipy.stats.qmc), seeded. GrainLearning's default, an unscrambled Halton sequence,
    puts its first points on a line in the higher dimensions (bases 7 and 11: the fourth and fifth parameters in
    proportion for the first seven samples) and its first point on every lower bound.

    >>> u = first_samples({"a": (0.0, 1.0), "b": (10.0, 20.0)}, 4)
    >>> u.shape, bool((u[:, 1] >= 10).all() and (u[:, 1] <= 20).all())
    ((4, 2), True)
    """
    from scipy.stats import qmc
    lo, hi = (np.array([float(bounds[n][i]) for n in bounds]) for i in (0, 1))
    unit = qmc.LatinHypercube(len(bounds), seed=seed, optimization="random-cd").random(samples)
    return lo + unit * (hi - lo)


SIGMA_CAP = 1.0         # the likelihood's widest sigma: an SD of 4.5 target ranges over four targets, where every
# sample of a filter here weighs the same to three decimals of the effective sample size


def run_inference(inference, system) -> None:
    """GrainLearning's IterativeBayesFilter.run_inference with its likelihood's sigma searched over log10 sigma from
    the floor (`sigma_lower_bound`) to the last iteration's sigma, at most SIGMA_CAP. GrainLearning's own search runs
    over sigma itself up to 1e6: where the effective sample size stays over its target down to the floor (the floor
    binds), the search's first points fall on the plateau where every weight is equal and it ends there, at a sigma
    of 1e5-1e6, its posterior the unweighted ensemble.

    >>> from types import SimpleNamespace as N
    >>> ess = lambda s: min(1.0, 0.4 + s)             # over the target 0.3 everywhere: the floor binds
    >>> f = N(data_assimilation_loop=lambda s, system, proposal: (ess(s) - 0.3) ** 2,
    ...       get_posterior_at_time=lambda t: None, posteriors=None)
    >>> system = N(sigma_lower_bound=0.0037, sigma_max=1e6, sigma_tol=1e-3, compute_estimated_params=lambda p: None)
    >>> inference = N(Bayes_filter=f, proposal=None, posterior=None)
    >>> run_inference(inference, system); system.sigma_max < 0.004     # within the search's tolerance of the floor
    True
    """
    from scipy import optimize
    loop = inference.Bayes_filter.data_assimilation_loop

    def miss(log_sigma: float) -> float:          # (ESS - target)²; a sigma so small every likelihood underflows
        value = loop(10.0 ** log_sigma, system, inference.proposal)    # (NaN weights) misses the most, 1
        return float(value) if np.isfinite(value) else 1.0

    lo, hi = np.log10(system.sigma_lower_bound), np.log10(min(system.sigma_max, SIGMA_CAP))
    x = lo if hi <= lo else optimize.minimize_scalar(miss, method="bounded", bounds=(lo, hi),
                                                     options={"xatol": 0.01}).x
    system.sigma_max = float(10.0 ** x)
    loop(max(system.sigma_max, system.sigma_tol), system, inference.proposal)
    inference.posterior = inference.Bayes_filter.get_posterior_at_time(-1)
    system.compute_estimated_params(inference.Bayes_filter.posteriors)


def calibrate(model, targets: dict, bounds: dict, samples: int = 40, iterations: int = 4,
              seed_ess: float = 0.3, seed: int = 0, batch: bool = False, scatter: dict | None = None) -> dict:
    """Fit `bounds`' parameters ({name: (lo, hi)}) so that model(params dict) -> {response: value} meets `targets`
    ({response: (lo, hi)}, each its stated uncertainty). Returns the posterior's mean, its coefficient of variation
    and the most probable sample, per parameter, and the ensemble of the last iteration (its parameters and
    weights). `seed`: the random state of the first samples (`first_samples`) and of the resampling, so a
    calibration repeats itself. `batch`: the model takes an iteration's list of parameter dicts at once and returns
    their responses in order (so it can run them side by side). `scatter`: each response's SD over packings, the
    likelihood's floor (`sigma_floor`); None leaves the spread to the effective sample size alone."""
    from grainlearning import BayesianCalibration, DynamicSystem
    names, responses = list(bounds), list(targets)
    holes = sorted(set(responses) & HOLE_METRICS)
    if holes:
        raise ValueError(f"calibrate: target(s) {', '.join(holes)} are hole metrics: allowed only bench responses "
                         "(a soil is calibrated on its own tests, never on the holes it is judged by)")
    bad = [r for r in responses if len(targets[r]) != 2 or not float(targets[r][0]) < float(targets[r][1])]
    if bad or len(responses) < 2:
        raise ValueError(f"calibrate: target {bad[0] if bad else ''}: allowed two targets or more, each a range "
                         "(lo, hi) with lo < hi (its width scales its misses)")
    floor = {} if scatter is None else {"sigma_lower_bound": sigma_floor(targets, scatter)}
    step = np.arange(len(responses))
    obs = (MIDDLE + step)[None, :]

    def run(calib):
        rows = [dict(zip(names, map(float, row))) for row in calib.system.param_data]
        outs = model(rows) if batch else [model(row) for row in rows]
        calib.system.set_sim_data([np.array([[in_ranges(out.get(r, np.nan), targets[r]) for r in responses]]) + step
                                   for out in outs])

    calib = BayesianCalibration.from_dict({
        "num_iter": iterations, "callback": run, "save_fig": -1,
        "system": {"system_type": DynamicSystem, "param_names": names,
                   "param_min": [float(bounds[n][0]) for n in names], "param_max": [float(bounds[n][1]) for n in names],
                   "num_samples": samples, "obs_data": obs, "obs_names": ["response"],
                   "ctrl_data": step, "inv_obs_weight": [1.0], "sim_name": "soil", **floor},
        "inference": {"Bayes_filter": {"ess_target": seed_ess, "scale_cov_with_max": True},
                      "sampling": {"max_num_components": 2, "random_state": seed}},
    })
    def initialize(system):                           # GrainLearning's own: an unscrambled Halton sequence
        system.param_data = first_samples(bounds, samples, seed)
        calib.inference.param_data_list.append(system.param_data)
    calib.inference.initialize = initialize
    calib.inference.run_inference = lambda system: run_inference(calib.inference, system)
    import contextlib
    import io
    import warnings
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():   # it prints every iteration
        warnings.simplefilter("ignore")
        calib.run()
    mean = calib.system.estimated_params[-1]
    cv = calib.system.estimated_params_cv[-1]
    best = calib.get_most_prob_params()
    sigmas = [float(x) for x in calib.inference.sigma_list]
    return {"names": names, "mean": dict(zip(names, map(float, mean))), "cv": dict(zip(names, map(float, cv))),
            "most_probable": dict(zip(names, map(float, best))), "samples": calib.system.param_data,
            "weights": calib.inference.posterior, "sigma": sigmas}
