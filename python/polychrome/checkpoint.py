"""Checkpoint files of renders run in tasks (docs/distributed.md, "Checkpoint and resume").

A checkpoint holds the merged pass sums of the finished tasks (and adaptive sampling's
per-pixel state), the passes of the groups ended so far and, for the group under way,
which pass ranges of which image tile are in those sums. It is an ``.npz`` file written
atomically (temporary file beside it, renamed over it), so an interrupted write leaves
the previous checkpoint. A token (a hash of the scene, its buffers and the settings that
change pixels) ties it to its render: resuming another scene or other settings is an
error naming the file, never a wrong image.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np

#: Format version written into every file.
VERSION = 1
#: Seconds between checkpoint writes while rendering (also written when interrupted and
#: at the end); tests set it to 0.
INTERVAL = 10.0
#: Settings that do not change pixels: a checkpoint stays valid across them (resume on
#: another cluster, with more threads, a longer time limit).
NEUTRAL = ("scheduler", "checkpoint", "resume", "threads", "denoise", "denoise_previews", "time_limit")


def token(scene_json: str, buffers, settings) -> str:
    """The hash that ties a checkpoint to a scene and the settings that change pixels."""
    defaults = {f.name: f.default for f in dataclasses.fields(settings) if f.name in NEUTRAL}
    return content_hash(scene_json, buffers, dataclasses.replace(settings, **defaults).to_json())


def content_hash(scene_json: str, buffers, settings_json: str) -> str:
    """SHA-256 of a scene description, its buffers (dtype, shape and bytes) and settings:
    what a checkpoint and a worker's scene cache are keyed by."""
    h = hashlib.sha256()
    h.update(scene_json.encode())
    for b in buffers:
        a = np.ascontiguousarray(b)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.data)
    h.update(settings_json.encode())
    return h.hexdigest()


@dataclasses.dataclass
class Progress:
    """The part of a render in a checkpoint: ``state`` (``PassRenderer.state()``),
    ``tile`` (tile side in pixels, 0: whole image) and ``finished``: per tile index, the
    (start, end) pass ranges of the group under way already in the sums."""

    state: dict
    tile: int
    finished: dict[int, list[tuple[int, int]]]


def save(path, tok: str, merge, tile: int, finished: dict[int, list[tuple[int, int]]]) -> None:
    """Writes ``merge``'s state atomically to ``path``."""
    path = Path(path)
    state = merge.state()
    meta = {
        "version": VERSION,
        "token": tok,
        "passes": int(state.pop("passes")),
        "nonfinite": int(state.pop("nonfinite")),
        "tile": int(tile),
        "finished": {str(k): [list(r) for r in v] for k, v in finished.items() if v},
    }
    arrays = {k: np.asarray(v) for k, v in state.items() if v is not None}
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as e:
        raise OSError(f"checkpoint {path}: cannot write ({e})") from None
    finally:
        if tmp.exists():
            tmp.unlink()
    # Left by a process killed mid-write (the checkpoint itself was never touched).
    for stale in path.parent.glob(f".{path.name}.*.tmp"):
        stale.unlink(missing_ok=True)


def load(path, tok: str) -> Progress | None:
    """The progress saved in ``path`` (None when there is no file); ValueError naming the
    file when it is not a checkpoint or belongs to another scene or settings."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            state = {k: z[k] for k in z.files if k != "meta"}
    except (OSError, ValueError, KeyError) as e:
        raise ValueError(f"checkpoint {path}: not a Polychrome checkpoint ({e})") from None
    if meta.get("version") != VERSION:
        raise ValueError(f"checkpoint {path}: format version {meta.get('version')}, this Polychrome reads {VERSION}")
    if meta.get("token") != tok:
        raise ValueError(
            f"checkpoint {path} was written for another scene or other settings (samples, size, seed, ...); "
            "delete it or render without resume"
        )
    state["passes"] = meta["passes"]
    state["nonfinite"] = meta["nonfinite"]
    state.setdefault("spectral", None)
    finished = {int(k): [(int(a), int(b)) for a, b in v] for k, v in meta["finished"].items()}
    return Progress(state=state, tile=int(meta["tile"]), finished=finished)
