"""A LeRobot dataset -> advise -> advice on a chunk -> a LeRobot dataset, with LeRobot itself at
both ends, for tests/lerobot_peer.rs.

    lerobot_roundtrip.py DIR

LeRobot 0.4.4's own writer (`LeRobotDataset.create`, no videos) writes two episodes whose
`observation.state` and `action` names are the positioning domain's in another order;
`advise.load_lerobot` reads them; `advise.advise_lerobot` slows frames 10..30 of episode 0 down;
LeRobot's own `LeRobotDataset` (offline) loads the result. Prints JSON of what each end saw.
"""

import json
import os
import sys

os.environ["HF_HUB_OFFLINE"] = "1"

import numpy as np  # noqa: E402
from lerobot.datasets.lerobot_dataset import LeRobotDataset  # noqa: E402

import advise  # noqa: E402


def main():
    root = sys.argv[1]
    src, out = f"{root}/src", f"{root}/out"
    features = {
        "observation.state": {"dtype": "float32", "shape": (3,),
                              "names": ["dheading", "dist2", "bearing"]},
        "action": {"dtype": "float32", "shape": (2,), "names": ["rot", "trans"]},
    }
    ds = LeRobotDataset.create("local/written", fps=30, features=features, root=src,
                               use_videos=False)
    for ep, n in enumerate([40, 25]):
        for i in range(n):
            ds.add_frame({
                "observation.state": np.array([0.01 * i, 2.0 - 0.04 * i, 0.1 * ep],
                                              dtype=np.float32),
                "action": np.array([0.05 * ep, 0.5 - 0.01 * i], dtype=np.float32),
                "task": "drive the base to the goal pose",
            })
        ds.save_episode()
    ds.finalize()

    loaded = advise.load_lerobot(src, task="positioning")
    result = advise.advise_lerobot(src, out, episode=0, frames=(10, 30), operator="slow_down",
                                   params={"rate": 0.3}, task="positioning")
    back = LeRobotDataset("local/advised", root=out)
    actions = np.stack([np.asarray(back[i]["action"], dtype=np.float64)
                        for i in range(len(back))])
    states = np.stack([np.asarray(back[i]["observation.state"], dtype=np.float64)
                       for i in range(len(back))])
    again = advise.load_lerobot(out, task="positioning")
    json.dump({
        "source_frames": int(len(loaded["actions"])),
        "source_trans_first": float(loaded["actions"][0][0]),
        "result": {k: v for k, v in result.items() if isinstance(v, (int, float, str))},
        "lerobot_frames": int(len(back)),
        "lerobot_episodes": int(back.num_episodes),
        "lerobot_task": back[0]["task"],
        "lerobot_sources": sorted({str(back[i]["advise.source"]) for i in range(len(back))}),
        "actions_equal": bool(np.array_equal(actions, again["actions"])),
        "states_equal": bool(np.array_equal(states, again["observations"])),
        "trans": actions[:, 0].tolist(),
        "source_trans": [float(v) for v in loaded["actions"][:40, 0]],
    }, sys.stdout)


if __name__ == "__main__":
    main()
