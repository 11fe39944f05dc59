#!/usr/bin/env bash
# The GPU benchmark in one command, for a machine with a GPU (or, slowly, lavapipe):
#
#   bash benches/gpu.sh            # REPEAT=7 frames a method, the papers' resolutions
#   SCALE=0.25 REPEAT=3 bash benches/gpu.sh   # a quick run at a quarter of each side
#
# Builds the release binary (or takes CAUSTICA_BIN), names the adapter wgpu picks (CAUSTICA_BACKEND / CAUSTICA_ADAPTER
# choose, as for the server), renders each method's canonical frame REPEAT times on one
# renderer (`caustica render --repeat`: the first frame is a warm-up that bakes, builds
# pipelines and fills caches) and prints a table of medians over the other frames: each GPU
# pass (timestamp queries, the `gpu:` stages; absent where the adapter has no timestamps), their
# sum, and the whole frame as the CLI sees it (CPU work, uploads and readback included). The
# light does not move between the frames, so they reuse the warm-up's shadow maps (no
# `shadow_maps` pass after it), as an interactive client that orbits the camera would. Bakes
# are made fresh (a private CAUSTICA_CACHE) and timed apart. The raw lines of every run stay
# in the folder printed at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
REPEAT=${REPEAT:-7}
SCALE=${SCALE:-1}
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  XDG_RUNTIME_DIR="$(mktemp -d)"
  chmod 700 "$XDG_RUNTIME_DIR"
  export XDG_RUNTIME_DIR
fi
out="$(mktemp -d)"
CAUSTICA_CACHE="$out/cache"
export CAUSTICA_CACHE
# CAUSTICA_BIN: a binary already built (else the release build of this checkout).
bin=${CAUSTICA_BIN:-}
if [ -z "$bin" ]; then
  cargo build --release --locked --bin caustica >&2
  bin=target/release/caustica
fi
nproc_=$(nproc)

size() { awk -v s="$SCALE" -v v="$1" 'BEGIN { v = int(v * s + 0.5); if (v < 16) v = 16; print v }'; }

# run NAME SCENE WIDTH HEIGHT [render flags...]: one method's frames; its lines in $out/NAME.txt
run() {
  local name=$1 scene=$2 w h
  w=$(size "$3")
  h=$(size "$4")
  shift 4
  echo "== $name: $scene ${w}x${h} $*" >&2
  if ! "$bin" render "scenes/$scene" --width "$w" --height "$h" --repeat "$REPEAT" \
      --out "$out/$name.png" "$@" >"$out/$name.txt" 2>"$out/$name.log"; then
    echo "   failed; the end of its log:" >&2
    tail -5 "$out/$name.log" >&2
  fi
}

# bake NAME SECONDS-FILE [bake args...]: a bake, timed
bake() {
  local name=$1
  shift
  echo "== bake $name: $*" >&2
  local t0 t1
  t0=$(date +%s.%N)
  "$bin" bake "$@" >"$out/bake-$name.log" 2>&1 || { tail -5 "$out/bake-$name.log" >&2; return 1; }
  t1=$(date +%s.%N)
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }' >"$out/bake-$name.s"
}

run direct glass-sphere-directional.json 800 600 --method direct
run csl glass-sphere-directional.json 800 600 --method csl
bake dynamic-csl csl scenes/glass-sphere-directional.json --dynamic --subdivisions 0 \
  --out "$out/sphere.csld" && run csl-dynamic glass-sphere-directional.json 800 600 \
  --method csl --bake "$out/sphere.csld"
run transport glass-sphere-point.json 640 480 --method transport
run pinhole mirror-ring-env.json 512 512 --method pinhole
run water pool-noon.json 800 600 --method water
run photons glass-sphere-directional.json 800 600 --method photons
run beams fog-glass-sphere-spot.json 640 480 --method beams

adapter=$(grep -h -o 'adapter="[^"]*"' "$out"/*.txt 2>/dev/null | head -1 | cut -d'"' -f2)
echo
echo "adapter: ${adapter:-unknown}; $nproc_ CPU threads; medians of $((REPEAT - 1)) frames after a warm-up; ms"
echo
printf '| %-12s | %-9s | %-58s | %9s | %9s |\n' method size "GPU passes" "GPU sum" frame
printf '| %-12s | %-9s | %-58s | %9s | %9s |\n' --- --- --- ---: ---:
for f in "$out"/*.txt; do
  name=$(basename "$f" .txt)
  awk -v name="$name" '
    /^repeat method=/ { for (i = 2; i <= NF; i++) if ($i ~ /^size=/) size = substr($i, 6) }
    /^repeat stage=/ {
      split($2, a, "="); split($3, b, "=")
      if (a[2] ~ /^gpu:/) { passes = passes sprintf("%s%s %.2f", sep, substr(a[2], 5), b[2]); sep = ", "; sum += b[2]; gpu = 1 }
      if (a[2] == "frame") frame = b[2]
    }
    END {
      if (size == "") { printf "| %-12s | %-9s | %-58s | %9s | %9s |\n", name, "-", "failed (see its log)", "-", "-"; exit }
      printf "| %-12s | %-9s | %-58s | %9s | %9.1f |\n", name, size, (gpu ? passes : "(no timestamps)"), (gpu ? sprintf("%.2f", sum) : "-"), frame
    }' "$f"
done
for s in "$out"/bake-*.s; do
  [ -e "$s" ] && echo "bake $(basename "$s" .s | cut -c6-): $(cat "$s") s"
done
echo
echo "raw lines and logs: $out"
