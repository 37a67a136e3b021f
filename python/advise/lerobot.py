"""LeRobot v3.0 datasets and a learner's dataset as pyarrow tables (``advise.to_arrow``).

pyarrow is imported when ``to_arrow`` is called, so ``import advise`` works without it.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np


def to_arrow(data: Mapping[str, Any], source: str = "demonstration") -> Any:
    """The frames of ``data`` (what ``advise.load_lerobot`` returns) as a ``pyarrow.Table``; or,
    for a learner's dataset (what ``BC.dataset()``/``LWR.dataset()`` return), its points with
    their provenance (see ``_dataset_table``).

    Columns: ``observation.state`` and ``action`` (fixed-size lists of float64, the domain's
    dimensions in order), ``timestamp``, ``episode_index``, ``frame_index``, and the provenance
    columns ``advise.source`` (``source`` for every frame) and ``advise.dataset`` (the directory
    the frames were read from, dictionary-encoded). The schema's metadata says the domain, its
    dimensions' names, the mapping and the fps. Built with pyarrow's own constructors from the
    numpy arrays.
    """
    pa = _pyarrow()
    if "source_id" in data:
        return _dataset_table(pa, data)
    n = len(data["episode_index"])

    def fixed(values: Any) -> Any:
        return _fixed(pa, values)

    columns = {
        "observation.state": fixed(data["observations"]),
        "action": fixed(data["actions"]),
        "timestamp": pa.array(np.asarray(data["timestamp"], dtype=np.float64)),
        "episode_index": pa.array(np.asarray(data["episode_index"], dtype=np.int64)),
        "frame_index": pa.array(np.asarray(data["frame_index"], dtype=np.int64)),
        "advise.source": pa.array([source] * n, pa.string()),
        "advise.dataset": pa.array([str(data["path"])] * n, pa.string()).dictionary_encode(),
    }
    metadata = {
        "advise.domain": str(data["domain"]),
        "advise.observation_names": ",".join(data["observation_names"]),
        "advise.action_names": ",".join(data["action_names"]),
        "advise.mapping": "; ".join(data["mapping"]),
        "advise.fps": repr(float(data["fps"])),
    }
    return pa.table(columns, metadata=metadata)


def _pyarrow() -> Any:
    try:
        import pyarrow as pa
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("advise.to_arrow needs pyarrow: pip install pyarrow") from e
    return pa


def _fixed(pa: Any, values: Any) -> Any:
    """Rows of float64 values as a fixed-size-list column."""
    arr = np.ascontiguousarray(values, dtype=np.float64)
    return pa.FixedSizeListArray.from_arrays(pa.array(arr.reshape(-1)), arr.shape[1])


def _dataset_table(pa: Any, data: Mapping[str, Any]) -> Any:
    """A learner's dataset as a table, a row a data point in dataset order: ``observation`` and
    ``action`` (fixed-size lists of float64), ``weight`` (m), and the provenance columns
    ``advise.source`` (``demonstration`` or ``advice``, dictionary-encoded), ``advise.source_id``,
    ``advise.index`` and ``advise.execution_index`` (-1 for a demonstration). The schema's
    metadata holds the domain, its dimensions' names and the demonstrations and advice records
    as JSON."""
    import json

    columns = {
        "observation": _fixed(pa, data["observations"]),
        "action": _fixed(pa, data["actions"]),
        "weight": pa.array(np.asarray(data["weights"], dtype=np.float64)),
        "advise.source": pa.array([str(x) for x in data["source"]], pa.string()).dictionary_encode(),
        "advise.source_id": pa.array(np.asarray(data["source_id"], dtype=np.int64)),
        "advise.index": pa.array(np.asarray(data["index"], dtype=np.int64)),
        "advise.execution_index": pa.array(np.asarray(data["execution_index"], dtype=np.int64)),
    }
    metadata = {
        "advise.domain": str(data["domain"]),
        "advise.observation_names": ",".join(data["observation_names"]),
        "advise.action_names": ",".join(data["action_names"]),
        "advise.demonstrations": json.dumps(list(data["demonstrations"])),
        "advise.advice": json.dumps(list(data["advice"])),
    }
    return pa.table(columns, metadata=metadata)
