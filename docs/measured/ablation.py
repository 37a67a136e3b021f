#!/usr/bin/env python3
"""Print docs/ablation.md's tables from docs/measured/{bc,aopi}-seeds-0-20.json (the protocol)
and docs/measured/ablation-{bc,aopi}-CHOICE.json (one choice reverted alone), as they came out.
A-OPI's protocol row is the first kernel rule's measurement (aopi-seeds-0-20-first-kernel.json),
the one its ablation runs were measured beside.
Run from the repository's root: python3 docs/measured/ablation.py"""
import json, os

M = "docs/measured"

def load(name):
    path = os.path.join(M, name)
    return json.load(open(path)) if os.path.exists(path) and os.path.getsize(path) > 0 else None

def pct(v):
    return f"{v['mean'] * 100:.0f}% ± {v['sd'] * 100:.0f}"

def claim(c, unit=""):
    d = c["difference"]
    held = len(c["seeds_held"])
    if unit == " points":
        return f"{held} of {d['seeds']}, {d['mean']:+,.0f} [{d['lo95']:+,.0f}, {d['hi95']:+,.0f}]"
    return f"{held} of {d['seeds']}, {d['mean']:+.3f}{unit} [{d['lo95']:+.3f}, {d['hi95']:+.3f}]"

def allheld(shape):
    return f"{len(shape['seeds_all_held'])} of {shape['seeds']}"

def bc():
    print("| run | initial | final (paper's rule) | teacher | final beats initial on success | final beats initial on length | final matches the teacher | all three | all three, directional |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, file in [("protocol", "bc-seeds-0-20.json")] + [
        (f"{n}. `--revert {c}`", f"ablation-bc-{c}.json") for n, c in [(1, "ball"), (2, "teacher"), (3, "chunks"), (4, "support")]
    ]:
        d = load(file)
        if d is None:
            print(f"| {name} | not run | | | | | | | |")
            continue
        cl = d["shape"]["claims"]
        print(f"| {name} | {pct(d['learner_initial_success'])} | {pct(d['learner_final_success'])} | {pct(d['teacher_success'])} | "
              f"{claim(cl[0])} | {claim(cl[1], ' m')} | {claim(cl[2])} | {allheld(d['shape'])} | {allheld(d['directional']['shape'])} |")

def aopi():
    print("| run | baseline | advised | hybrid | teleoperation | advised beats baseline | hybrid beats baseline | advised matches teleop | hybrid matches teleop | advised dataset smaller | hybrid dataset smaller | all six |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, file in [("protocol", "aopi-seeds-0-20-first-kernel.json")] + [
        (f"{n}. `--revert {c}`", f"ablation-aopi-{c}.json") for n, c in [(2, "teacher"), (5, "advisor"), (6, "stopping"), (7, "rate")]
    ]:
        d = load(file)
        if d is None:
            print(f"| {name} | not run | | | | | | | | | | |")
            continue
        a = d["arms"]
        cl = d["shape"]["claims"]
        cells = [claim(c, " points" if "dataset" in c["claim"] else "") for c in cl]
        print(f"| {name} | {pct(a['baseline']['success_rate'])} | {pct(a['advised']['success_rate'])} | {pct(a['hybrid']['success_rate'])} | "
              f"{pct(a['teleop']['success_rate'])} | " + " | ".join(cells) + f" | {allheld(d['shape'])} |")

def extra():
    for study, choices in [("bc", ["ball", "teacher", "chunks", "support"]), ("aopi", ["teacher", "advisor", "stopping", "rate"])]:
        for c in choices:
            d = load(f"ablation-{study}-{c}.json")
            if d is None:
                continue
            runs = d["runs"]
            if study == "bc":
                pts = sum(r["demo_points"] for r in runs) / len(runs)
                ends = {}
                for r in runs:
                    for k, v in r["teacher"]["endings"].items():
                        ends[k] = ends.get(k, 0) + v / len(runs)
                fl = sum(r["critiques"]["chunks_flagged"] for r in runs) / len(runs)
                pf = sum(r["critiques"]["points_flagged"] for r in runs) / max(1, sum(r["critiques"]["chunks_flagged"] for r in runs))
                print(f"bc {c}: demo points {pts:,.0f}; teacher endings {({k: round(v, 1) for k, v in ends.items()})}; chunks a seed {fl:.0f}, points a chunk {pf:.0f}")
            else:
                pts = sum(r["seed_demo_points"] for r in runs) / len(runs)
                best = {arm: sum(r["arms"][arm]["best"]["success_rate"] for r in runs) / len(runs) for arm in ["advised", "hybrid", "teleop"]}
                print(f"aopi {c}: seed demo points {pts:,.0f}; best-on-test {({k: round(v * 100) for k, v in best.items()})}")

if __name__ == "__main__":
    bc(); print(); aopi(); print(); extra()
