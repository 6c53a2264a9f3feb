"""Scene part: the disk scene's checkpoint (scripts/disk_parts.py). Every `checkpoint_every` s of wall time an
unfinished run saves itself: checkpoint-<step>.yade.gz (YADE's whole scene, bonds included) and checkpoint.json,
written after it and naming it (the parts' states and the energy so far), so a run killed or cut off goes on from
there when started again with the same parameters; both go when the run finishes. What it cannot carry is YADE's
collider, rebuilt on loading (results/scenes/README.md): a resumed run records where it was resumed.
"""
from __future__ import annotations

import json
from pathlib import Path

from analysis.core.io import atomic_write

CHECKPOINT = "checkpoint.json"   # the run's state, naming the scene file it goes with


def save_checkpoint(out: Path, state: dict):
    """YADE's scene, then the run's Python state naming it (the json replaced atomically, last), so the
    checkpoint.json on disk always names a whole scene file; then the older scene files go."""
    from yade import O
    scene = f"checkpoint-{O.iter}.yade.gz"
    tmp = out / f".tmp-{scene}"              # same ending: YADE picks the format by it
    O.save(str(tmp))
    tmp.replace(out / scene)
    atomic_write(out / CHECKPOINT, json.dumps({**state, "scene": scene}))
    for old in out.glob("checkpoint-*.yade.gz"):
        if old.name != scene:
            old.unlink()


def load_checkpoint(out: Path) -> dict:
    """The saved scene loaded into YADE, and the checkpoint's state; a checkpoint that does not match is an
    error naming the way out."""
    from yade import O
    ck = json.loads((out / CHECKPOINT).read_text())
    if "motion" not in ck:
        raise RuntimeError(f"{out / CHECKPOINT} was written by an older version of the disk scene; run again with "
                           "--rerun")
    O.load(str(out / ck["scene"]))
    if O.iter != ck["iter"]:
        raise RuntimeError(f"{out / ck['scene']} is at step {O.iter}, its checkpoint.json at {ck['iter']}; "
                           "run again with --rerun")
    return ck


def drop_checkpoint(out: Path):
    """The checkpoint's files, and any half-written scene file of a process killed while saving."""
    (out / CHECKPOINT).unlink(missing_ok=True)
    for old in [*out.glob("checkpoint-*.yade.gz"), *out.glob(".tmp-checkpoint-*")]:
        old.unlink()
