"""Write a large operator file for measuring `advise check` (issue 31): the standard operators
(operators/*.adv, doc comments included, domains left out) renamed `NAME_k` for k = 0, 1, ...
until the file holds at least the given number of megabytes (10^6 bytes). The same text as
`large_operators` in benches/check.rs.

    python3 benches/large_operators.py 50 /tmp/large.adv
    /usr/bin/time -v target/release/advise check /tmp/large.adv

With `--bare`, the operators without their doc comments (denser code, the harder case). With
`--one`, a single operator of that size instead (statements `trans = trans + 1`), which the
checker refuses (advise::check::too_many_nodes) after parsing it.
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def standard_operators():
    """The operator items of the standard files (each with its doc comments), domains dropped."""
    items = []
    for name in ("positioning.adv", "interception.adv"):
        lines = (ROOT / "operators" / name).read_text().split("\n")
        docs, current = [], None
        for line in lines + [""]:
            starts = line.startswith("operator ") or line.startswith("domain ")
            if starts or line.startswith("///") or not line.strip() or line.startswith("// "):
                if current is not None and any(l.startswith("operator ") for l in current):
                    items.append("\n".join(current) + "\n")
                current = None
            if line.startswith("///"):
                docs.append(line)
            elif starts:
                current = docs + [line]
                docs = []
            elif current is not None:
                current.append(line)
            else:
                docs = []
    # Each item ends at the first blank line or comment after it (as the standard files are laid out).
    assert items, "no operator found in operators/"
    return items


def large_operators(megabytes, bare=False):
    items = standard_operators()
    if bare:
        items = ["".join(l for l in i.splitlines(True) if not l.startswith("///")) for i in items]
    out, size, k = [], 0, 0
    while size < megabytes * 1_000_000:
        for item in items:
            renamed = re.sub(r"^operator (\w+)", lambda m: f"operator {m.group(1)}_{k}", item, count=1, flags=re.M)
            out.append(renamed)
            size += len(renamed)
        k += 1
    return "".join(out)


def one_operator(megabytes):
    line = "  trans = trans + 1\n"
    count = megabytes * 1_000_000 // len(line)
    return "operator huge for positioning on action {\n" + line * count + "}\n"


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    megabytes, out = int(args[0]), pathlib.Path(args[1])
    if "--one" in sys.argv:
        text = one_operator(megabytes)
    else:
        text = large_operators(megabytes, bare="--bare" in sys.argv)
    out.write_text(text)
    print(f"{out}: {len(text)} bytes")


if __name__ == "__main__":
    main()
