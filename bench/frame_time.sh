#!/bin/sh
# Issue #20's frame-time table: `splitray animate --compare` (every animation strategy on the
# same frames, 2 threads, 1024x768 primary pass + one shadow ray per hit) and the kd run
# (coherent rebuild against golden from scratch) on every shared animated sequence. Writes
# bench/results/frame_time/SEQUENCE.{compare.json,compare.md,compare.png,kd.json}.
# usage: bench/frame_time.sh [THREADS]
set -eu
cd "$(dirname "$0")/.."
S=build/apps/splitray/splitray
D=../shared/data
OUT=bench/results/frame_time
T=${1:-2}
run() {  # name, frames argument, frame count
  "$S" animate "$2" --frames "$3" -t "$T" --compare --json-out "$OUT/$1.compare.json" \
    --plot "$OUT/$1.compare.png" > "$OUT/$1.compare.md"
  "$S" animate "$2" --frames "$3" -t "$T" --rays 0 --pass-width 0 --json-out "$OUT/$1.kd.json" \
    > /dev/null
}
run anim_horse_collapse "$D/anim_horse_collapse/frames/horse-collapse-%02d.obj.gz" 53
run anim_samba "$D/anim_samba/frames" 60
run anim_elephant_gallop "$D/anim_elephant_gallop/frames" 24
run anim_walking_cat "$D/anim_walking_cat/frames" 35
run anim_md2_faerie "$D/anim_md2_faerie/faerie.md2" 60
run anim_bart_museum "$D/anim_bart_museum/aff/museum5.aff" 60
run anim_bart_robots "$D/anim_bart_robots/aff/Robot.aff" 30
