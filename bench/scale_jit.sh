#!/bin/sh
# Generated code at scale (docs/design.md): whole `multibond run` processes on a chain of N bodies
# (bench/make_chain.py), each first with an empty JIT cache, then again with the cache it filled.
# Wall time, CPU time (user + system, the compilers included: a figure that a machine shared with
# other work changes less) and peak memory (resident set of the largest process) from
# /usr/bin/time -v. A run that fails (e.g. --jit on past the compile budget) shows "failed".
#
#   --jit auto: the run starts on the interpreter and switches when the code is loaded
#   --jit on:   the run waits for the code (the compile time itself)
#
# Usage: bench/scale_jit.sh [multibond binary] [N ...]   (default: build/ci/apps/multibond 10 100 300 1000)
set -eu
here=$(cd "$(dirname "$0")" && pwd)
bin=${1:-$here/../build/ci/apps/multibond}
[ $# -gt 0 ] && shift
sizes=${*:-10 100 300 1000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# One process: "wall_s cpu_s peak_MiB" of `multibond run` with the cache folder $1 and the options after it.
measure() {
  cache=$1
  shift
  if ! MULTIBOND_CACHE=$cache /usr/bin/time -v "$bin" run "$@" -o "$work/out" >/dev/null 2>"$work/time.txt"; then
    printf '%24s' failed
    return
  fi
  awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, p, ":"); w = (n == 3) ? p[1] * 3600 + p[2] * 60 + p[3] : p[1] * 60 + p[2] }
              /User time/ { c += $2 } /System time/ { c += $2 }
              /Maximum resident set size/ { m = $2 / 1024 }
              END { printf "%8.2f %7.2f %7.0f", w, c, m }' "$work/time.txt"
}

printf '%6s %-5s %24s %24s\n' N jit "first: wall s, CPU s, MiB" "cached: wall s, CPU s, MiB"
for n in $sizes; do
  python3 "$here/make_chain.py" "$n" >"$work/chain.yaml"
  for jit in auto on; do
    cache=$(mktemp -d "$work/cache.XXXXXX")
    first=$(measure "$cache" "$work/chain.yaml" --jit "$jit")
    cached=$(measure "$cache" "$work/chain.yaml" --jit "$jit")
    printf '%6s %-5s %24s %24s\n' "$n" "$jit" "$first" "$cached"
  done
done
