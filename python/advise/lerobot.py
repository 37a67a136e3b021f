"""LeRobot v3.0 datasets as pyarrow tables (``advise.to_arrow``).

pyarrow is imported when ``to_arrow`` is called, so ``import advise`` works without it.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np


def to_arrow(data: Mapping[str, Any], source: str = "demonstration") -> Any:
    """The frames of ``data`` (what ``advise.load_lerobot`` returns) as a ``pyarrow.Table``.

    Columns: ``observation.state`` and ``action`` (fixed-size lists of float64, the domain's
    dimensions in order), ``timestamp``, ``episode_index``, ``frame_index``, and the provenance
    columns ``advise.source`` (``source`` for every frame) and ``advise.dataset`` (the directory
    the frames were read from, dictionary-encoded). The schema's metadata says the domain, its
    dimensions' names, the mapping and the fps. Built with pyarrow's own constructors from the
    numpy arrays.
    """
    try:
        import pyarrow as pa
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("advise.to_arrow needs pyarrow: pip install pyarrow") from e

    n = len(data["episode_index"])

    def fixed(values: Any) -> Any:
        arr = np.ascontiguousarray(values, dtype=np.float64)
        return pa.FixedSizeListArray.from_arrays(pa.array(arr.reshape(-1)), arr.shape[1])

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
