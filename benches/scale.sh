#!/bin/sh
# The scale benchmark end to end (issue 36): `advise run` loading N synthetic positioning
# demonstrations from a CSV file (1,000-point episodes, written by benches/scale_demos.py), then
# `advise resume` of the journal it wrote. Prints for each: wall time,
# CPU time and peak resident memory (GNU time), and the journal's and sidecars' sizes.
#
#   cargo build --release && benches/scale.sh 1000000 5000000
#
# ADVISE (default target/release/advise) and ADVISE_SCALE_DIR (default target/scale) may be set.
# Runs under `nice -n 10`; the CSV of 20M points is about 1 GB, the measurement needs some 3 GB.
set -eu
ADVISE=$(realpath "${ADVISE:-target/release/advise}")
DIR=${ADVISE_SCALE_DIR:-target/scale}
mkdir -p "$DIR"
DIR=$(realpath "$DIR")
for N in "$@"; do
    CSV="$DIR/demos-$N.csv"
    if [ ! -f "$CSV" ]; then
        nice -n 10 python3 "$(dirname "$0")/scale_demos.py" "$N" >"$CSV.tmp" && mv "$CSV.tmp" "$CSV"
    fi
    HOME_DIR="$DIR/home-$N"
    rm -rf "$HOME_DIR"
    mkdir -p "$HOME_DIR"
    # The run queries both learners, which builds their trees: the session is ready then.
    printf 'load demos %s\nrun goal 2 -1 0\n' "$CSV" >"$DIR/load-$N.adv"
    echo "== $N points ($(du -m "$CSV" | cut -f1) MB of CSV)"
    ADVISE_HOME="$HOME_DIR" nice -n 10 /usr/bin/time -f "load and ready: %e s (CPU %U s user + %S s system), peak resident %M KB" \
        "$ADVISE" run "$DIR/load-$N.adv" --demos 0 2>&1 | grep -E "^loaded|^ran|load and ready" | sed 's/^/  /'
    JOURNAL=$(find "$HOME_DIR" -name '*.jsonl' | head -n 1)
    echo "  journal: $(wc -c <"$JOURNAL") bytes; sidecars: $(cat "$(dirname "$JOURNAL")"/demos-*.parquet | wc -c) bytes"
    ADVISE_HOME="$HOME_DIR" nice -n 10 /usr/bin/time -f "resume: %e s (CPU %U s user + %S s system), peak resident %M KB" \
        "$ADVISE" resume "$JOURNAL" </dev/null 2>&1 | grep -E "^resumed|^resume:" | sed 's/^/  /'
done
