#!/usr/bin/env bash
# The whole test suite from a fresh clone: install the Debian packages, build everything
# (Release, into build/), run every test through ctest, then check the command-line program
# end to end. Exits non-zero on the first failure. ../shared/data is used when present;
# tests that need it are skipped with a message otherwise.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

jobs=$(nproc)
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$jobs"
ctest --test-dir build --output-on-failure -j 2 --timeout 900

echo "== command-line checks"
splitray=build/apps/splitray/splitray
"$splitray" --help > /dev/null
for command in render build trace knn animate view train bench "bench build-trace" "bench bvh" "bench knn" "bench hybrid" "bench neural"; do "$splitray" $command --help > /dev/null; done
"$splitray" build data/horse/horse.obj.gz --accel kd

# kd and brute must find the same closest hits: compare hits and id_checksum of two `trace
# --json` outputs (what: the case, for the message).
field() { sed -n "s/^ *\"$1\": \([^,]*\),\?$/\1/p"; }
same_hits() {
  local what=$1 kd=$2 brute=$3 key a b
  for key in hits id_checksum; do
    a=$(field "$key" <<< "$kd")
    b=$(field "$key" <<< "$brute")
    if [[ -z "$a" || "$a" != "$b" ]]; then
      echo "FAILED: $what: kd $key=$a, brute $key=$b" >&2
      exit 1
    fi
  done
}
for kind in primary random; do
  kd=$("$splitray" trace data/horse/horse.obj.gz --accel kd --kind "$kind" --rays 20000 --json)
  brute=$("$splitray" trace data/horse/horse.obj.gz --accel brute --kind "$kind" --rays 20000 --json)
  same_hits "trace --kind $kind" "$kd" "$brute"
  echo "trace --kind $kind: kd and brute agree (hits $(field hits <<< "$kd"), id_checksum $(field id_checksum <<< "$kd"))"
done

# The ten Sponza triangles that float clipping lost (data/regress_kd_clip/SOURCE.md): every kd
# builder agrees with brute force on a million random rays.
fixture=data/regress_kd_clip/kd_clip_10tris.obj
rays=(--kind random --rays 1000000 --seed 1 --json)
brute=$("$splitray" trace "$fixture" --accel brute "${rays[@]}")
for builder in sah golden binned; do
  kd=$("$splitray" trace "$fixture" --accel kd --builder "$builder" "${rays[@]}")
  same_hits "trace $fixture --builder $builder" "$kd" "$brute"
done
echo "trace $fixture: every kd builder agrees with brute on 10^6 random rays (hits $(field hits <<< "$brute"))"

# A failing command exits non-zero with a message and leaves no output file behind.
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
if "$splitray" render "$out/missing.obj" -o "$out/x.png" 2> "$out/err"; then
  echo "FAILED: render of a missing file succeeded" >&2
  exit 1
fi
grep -q "missing.obj" "$out/err" || { echo "FAILED: error does not name the file" >&2; exit 1; }
[[ -z "$(ls -A "$out" | grep -v '^err$')" ]] || { echo "FAILED: output left behind" >&2; exit 1; }
# Materials and textures from the files, HDR output, and an unknown image format refused.
"$splitray" render data/spider/spider.obj -W 160 -H 120 -o "$out/spider.exr" > /dev/null
[[ -s "$out/spider.exr" ]] || { echo "FAILED: no spider.exr" >&2; exit 1; }
if "$splitray" render data/spider/spider.obj -o "$out/spider.jpg" 2> "$out/err"; then
  echo "FAILED: render to .jpg succeeded" >&2
  exit 1
fi
[[ ! -e "$out/spider.jpg" ]] || { echo "FAILED: .jpg written" >&2; exit 1; }
echo "== all checks passed"
