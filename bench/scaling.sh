#!/usr/bin/env bash
# The scaling measurements of docs/scaling.md: the chain of bench/make_chain.py at N bodies,
# `multibond run` with the JIT off (the plan interpreter: no compiler's time in the figures) and
# `multibond check`, each phase's wall time from run.json's phase_seconds, the peak memory
# (maximum resident set) from /usr/bin/time. Writes docs/figures/scaling.csv and plots it with
# gnuplot into docs/figures/scaling-time.svg and scaling-memory.svg.
#
# Usage: bench/scaling.sh [path/to/multibond] [N ...]
#   default binary build/release/apps/multibond (else build/ci/apps/multibond);
#   default N: 10 100 1000 5000 (check also at 10000)
#        bench/scaling.sh --plot-only    (the figures again from docs/figures/scaling.csv)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="$here/docs/figures"
plot_only=0
[[ "${1:-}" == --plot-only ]] && plot_only=1 && shift
bin="${1:-}"
if [[ -z "$bin" ]]; then
  bin="$here/build/release/apps/multibond"
  [[ -x "$bin" ]] || bin="$here/build/ci/apps/multibond"
fi
shift || true
sizes=("$@")
[[ ${#sizes[@]} -gt 0 ]] || sizes=(10 100 1000 5000)
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
csv="$out/scaling.csv"
if [[ $plot_only == 0 ]]; then
phases="load causality compile_plan constraints generate_code setup integrate write_results"
echo "model,N,states,$(echo $phases | tr ' ' ','),command_wall_s,cpu_s,max_rss_kB" > "$csv"

# One `multibond run` of a chain: a row of scaling.csv.
measure_run() {  # kind N extra-options...
  local kind="$1" n="$2"; shift 2
  local model="$work/${kind}_$n.yaml" dir="$work/${kind}_$n"
  python3 "$here/bench/make_chain.py" "$n" $([[ $kind == rigid ]] && echo --rigid) > "$model"
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$bin" run "$model" -o "$dir" --jit off -q "$@" > /dev/null
  read -r wall user sys rss < "$work/time"
  python3 - "$dir/run.json" "$kind" "$n" "$user" "$sys" "$rss" "$phases" >> "$csv" <<'PY'
import json, sys
run = json.load(open(sys.argv[1]))
kind, n, user, sys_s, rss, phases = sys.argv[2:8]
p = run["phase_seconds"]
states = run.get("states", "")
print(",".join([kind, n, str(states)] + [f"{p[k]:.6g}" for k in phases.split()] +
               [f"{run['command_wall_seconds']:.6g}", f"{float(user) + float(sys_s):.6g}", rss]))
PY
  echo "run $kind N=$n: $(tail -1 "$csv")" >&2
}

# `multibond check` of a chain (load, causality, compile; no run): wall time and memory.
measure_check() {  # N
  local n="$1" model="$work/check_$1.yaml"
  python3 "$here/bench/make_chain.py" "$n" > "$model"
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$bin" check "$model" > /dev/null
  read -r wall user sys rss < "$work/time"
  echo "check,$n,,,,,,,,,,$wall,$(python3 -c "print(f'{$user + $sys:.6g}')"),$rss" >> "$csv"
  echo "check N=$n: $(tail -1 "$csv")" >&2
}

for n in "${sizes[@]}"; do
  measure_run compliant "$n"
  # The rigid chain is not stiff (no joint springs): an explicit method; its structural Jacobian
  # would be dense (the multipliers couple every state).
  [[ $n -le 1000 ]] && measure_run rigid "$n" --solver dopri5
  measure_check "$n"
done
if [[ " ${sizes[*]} " == *" 5000 "* ]]; then measure_check 10000; fi
fi

cd "$out"
gnuplot <<'GP'
set datafile separator ","
set terminal svg size 900,560 dynamic font "sans,12"
set logscale xy
set format y "10^{%L}"
set xlabel "bodies N"
set key outside right
set grid
set output "scaling-time.svg"
set title "multibond: wall time per phase, compliant chain (JIT off)"
set ylabel "wall time [s]"
plot for [c in "4 5 6 9 10 11"] "< grep '^compliant' scaling.csv" using 2:(column(int(c)) > 0 ? column(int(c)) : NaN) \
       with linespoints title word("x x x load causality compile-plan x x setup integrate write-results", int(c)), \
     "< grep '^check' scaling.csv" using 2:12 with linespoints lw 2 title "check (whole command)", \
     "< grep '^rigid' scaling.csv" using 2:7 with linespoints dt 2 title "constraints setup (rigid chain)", \
     "< grep '^compliant' scaling.csv" using 2:(1e-4*$2) with lines dt 3 lc rgb "gray" title "slope 1 (linear)"
set output "scaling-memory.svg"
set title "multibond: peak memory (maximum resident set)"
set ylabel "memory [MB]"
set format y "%g"
plot "< grep '^compliant' scaling.csv" using 2:($14/1024) with linespoints title "run, compliant chain", \
     "< grep '^rigid' scaling.csv" using 2:($14/1024) with linespoints title "run, rigid chain", \
     "< grep '^check' scaling.csv" using 2:($14/1024) with linespoints title "check", \
     "< grep '^compliant' scaling.csv" using 2:(0.12*$2) with lines dt 3 lc rgb "gray" title "slope 1 (linear)"
GP
echo "wrote $csv, $out/scaling-time.svg, $out/scaling-memory.svg" >&2
