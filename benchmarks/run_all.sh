#!/bin/sh
# Full benchmark runs into benchmarks/results/ (see benchmarks/README.md). Run on a quiet
# machine; each subcommand's log goes next to its results.
set -u
cd "$(dirname "$0")/.."
out=benchmarks/results
mkdir -p "$out"
status=0
for which in scaling effects peers accuracy; do
    echo "== melange-ti bench $which"
    if ! melange-ti bench "$which" --out "$out" > "$out/$which.log" 2>&1; then
        echo "bench $which failed; see $out/$which.log"
        status=1
    fi
    grep -v '^\[Taichi\]' "$out/$which.log" | tail -n 30
done
exit $status
