#!/usr/bin/env bash
# Regenerates the checked-in speed-against-error report, docs/bench/ (issue 6):
#
#   bash scripts/bench_report.sh
#
# Builds cdsm (Release, CPU backend, no GL, the OpenVDB loader for the smoke
# scene: fragments from the exact CPU ray
# caster, so runs are comparable across machines) in build-report/, runs
# `cdsm bench` on the default scene and on the CT "virtual X-ray" scene
# (content/scenes/ct_xray.json; the default scene stands in while it is
# missing), plus the paper's Table 4 experiment (nodes per texel against
# epsilon, 4 x 256^2 maps), and writes docs/bench/README.md with the commit,
# the machine, every table and plot. Under 10 minutes on 2 cores.
#
# Environment: CDSM_BENCH_BUILD (build directory), CDSM_BENCH_REPEAT (timed
# runs per configuration, default 3), CDSM_BENCH_QUICK=1 (a tiny sweep, to
# test this script), CDSM_CACHE_DIR (reference cache, see cdsm bench --help).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$ROOT"
BUILD=${CDSM_BENCH_BUILD:-$ROOT/build-report}
OUT=$ROOT/docs/bench
REPEAT=${CDSM_BENCH_REPEAT:-3}
QUICK=${CDSM_BENCH_QUICK:-0}
PY=/usr/bin/python3
START=$(date +%s)
LOAD_START=$(cut -d' ' -f1-3 /proc/loadavg)

echo "== building cdsm in $BUILD" >&2
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCDSM_CUDA=OFF -DCDSM_GL=OFF -DCDSM_VDB=ON \
  -DCDSM_TESTS=OFF -DCDSM_EDITOR=ON >/dev/null
ninja -C "$BUILD" cdsm >/dev/null
CDSM=$BUILD/cdsm

CT=content/scenes/ct_xray.json
CT_NOTE=""
if [ ! -f "$CT" ]; then
  CT=content/scenes/default.json
  CT_NOTE="content/scenes/ct_xray.json is missing in this tree: the Table 4 experiment ran on the default scene instead."
fi

WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
# The thesis' DSMs hold every object; the CT scene's walls only receive
# shadows. A copy where they cast too, for the Table 4 comparison.
CT_CAST=$WORK/$(basename "${CT%.json}")_walls_cast.json
"$PY" - "$CT" "$CT_CAST" <<'EOF'
import json, os, sys
src, dst = sys.argv[1], sys.argv[2]
scene = json.load(open(src))
for o in scene.get("objects", []):
    o["casts_shadows"] = True
# Relative file references keep working from the copy's directory.
scene["comment"] = "copy of %s with every object casting shadows (made by scripts/bench_report.sh)" % src
json.dump(scene, open(dst, "w"), indent=1)
EOF
# Resolve relative paths of the copy against the original scene's directory.
if grep -q '"file": "[^$/]' "$CT_CAST"; then cp "$CT_CAST" "$(dirname "$CT")/.bench_walls_cast.json"; CT_CAST=$(dirname "$CT")/.bench_walls_cast.json; trap 'rm -rf "$WORK" "$CT_CAST"' EXIT; fi

SIZE=(--width 240 --height 160)
# Every method: the DSM, the conventional map, opacity slices, AVSM-style
# nodes, deep opacity maps, Fourier opacity maps, moments.
ALL_METHODS=dsm,sm,osm16,osm32,osm64,avsm4,avsm8,avsm16,dom4,dom8,dom16,fom4,fom8,fom16,mom4,mom8
COMMON=(--fragments cpu --repeat "$REPEAT" "${SIZE[@]}")
if [ "$QUICK" = 1 ]; then
  ALL_METHODS=dsm,sm,osm16,avsm4,dom4,fom4,mom4
  DEFAULT_SWEEP=(--sweep eps=0.01,0.1 --sweep res=256 --methods dsm,sm,osm16,avsm4)
  CT_SWEEP=(--sweep eps=0.01 --sweep res=256 --methods dsm,sm)
  COMMON=(--fragments cpu --repeat 1 --warmup 0 "${SIZE[@]}")
else
  DEFAULT_SWEEP=(--sweep eps=0,0.001,0.005,0.01,0.05,0.1,0.2 --sweep res=256,512,1024 --methods "$ALL_METHODS")
  CT_SWEEP=(--sweep eps=0,0.001,0.01,0.05,0.1,0.2 --sweep res=256,512 --methods "$ALL_METHODS")
fi
# Every method on the scenes of the comparison (issue 31): the DSM at three
# epsilons, every baseline at N = 4, 8, 16 where it allows.
SERIES=(--sweep eps=0.001,0.01,0.1 --methods "$ALL_METHODS" "${COMMON[@]}")
LAYOUTS=(--methods dsm --sweep eps=0.01 --sweep res=512 --layouts packed,fixed,chunked "${COMMON[@]}" --no-plot)
CLUSTERS=(--methods dsm --sweep eps=0.01 --sweep res=256 --sweep clusters=1,2,4,8 "${COMMON[@]}" --no-plot)
TABLE4=(--methods dsm --sweep eps=0.01,0.05,0.1,0.2 --sweep res=256 --sweep clusters=4 --repeat 1 --warmup 0
        --fragments cpu "${SIZE[@]}" --no-plot)

run() {  # run NAME ARGS... : cdsm bench into $WORK/NAME, its stdout kept
  local name=$1; shift
  echo "== cdsm bench $*" >&2
  "$CDSM" bench "$@" --out "$WORK/$name" > "$WORK/$name.log"
  cat "$WORK/$name.log" >&2
}
# --refresh-reference: the reference renderer's time is measured in this run too.
run default content/scenes/default.json "${DEFAULT_SWEEP[@]}" "${COMMON[@]}" --refresh-reference
run ct "$CT" "${CT_SWEEP[@]}" "${COMMON[@]}" --refresh-reference
run layouts content/scenes/default.json "$CT" "${LAYOUTS[@]}"
run clusters content/scenes/default.json content/scenes/sparse.json "${CLUSTERS[@]}"
# The baseline clustering competes with: parallel-split (cascaded) DSMs.
SPLITS=(--methods pssm2,pssm4 --sweep eps=0.01 --sweep res=256 --sweep clusters=1 "${COMMON[@]}" --no-plot)
run splits content/scenes/sparse.json "${SPLITS[@]}"
# The sun: one orthographic map, four clustered ones, cascades (issue 29).
SUN=(--methods dsm,pssm4 --sweep eps=0.01 --sweep res=512,1024 --sweep clusters=1,4 "${COMMON[@]}" --no-plot)
run sun content/scenes/sun_clouds.json "${SUN[@]}"
# Soft shadows (issue 30): light sizes against the area-sampled reference
# (256 shadow rays per lookup), the estimated penumbra beside a fixed-kernel
# PCF of the same taps and the hard lookup. Each light size is its own
# scene variant with its own reference.
SOFT=(--methods dsm --sweep eps=0.01 --sweep penumbra=estimated,fixed_kernel,hard "${COMMON[@]}" --no-plot)
run soft content/scenes/default.json "${SOFT[@]}" --sweep radius=0.05,0.15,0.3
run soft_sun content/scenes/sun_glass.json "${SOFT[@]}" --sweep angular_diameter=0.53,2
# The smoke at 96 x 64: its area reference (256 rays per lookup through a dense
# column) costs about 38 minutes at 240 x 160 on 2 cores.
run soft_smoke content/scenes/smoke_gltf.json "${SOFT[@]}" --sweep radius=0.15 --width 96 --height 64
run table4 "$CT" "$CT_CAST" "${TABLE4[@]}"
# Every method on the stained glass (grey baselines: see the text), the sun's
# clouds (four clustered orthographic maps) and a smoke-only column.
GLASS_RES=(--sweep res=256,512)
SUN_RES=(--sweep res=512 --sweep clusters=4)
SMOKE_RES=(--sweep res=256,512)
if [ "$QUICK" = 1 ]; then GLASS_RES=(--sweep res=128); SUN_RES=(--sweep res=128 --sweep clusters=4); SMOKE_RES=(--sweep res=128); fi
run glass content/scenes/stained_glass.json "${SERIES[@]}" "${GLASS_RES[@]}"
run sunm content/scenes/sun_clouds.json "${SERIES[@]}" "${SUN_RES[@]}"
run smoke content/scenes/smoke_column.json "${SERIES[@]}" "${SMOKE_RES[@]}"
# Coloured shadows: RGB maps against every map scalar on the stained-glass scene.
run colour content/scenes/stained_glass.json --methods dsm,dsmgrey --sweep eps=0.01 --sweep res=512 "${COMMON[@]}" --no-plot

mkdir -p "$OUT"
rm -f "$OUT"/*.csv "$OUT"/*.png "$OUT"/*.md
DEF_NAME=default
CT_NAME=$(basename "${CT%.json}")
cp "$WORK/default/$DEF_NAME.csv" "$WORK/default/$DEF_NAME.png" "$OUT/"
cp "$WORK/default/results.md" "$OUT/$DEF_NAME.md"
if [ "$CT_NAME" != "$DEF_NAME" ]; then
  cp "$WORK/ct/$CT_NAME.csv" "$WORK/ct/$CT_NAME.png" "$OUT/"
  cp "$WORK/ct/results.md" "$OUT/$CT_NAME.md"
fi
cp "$WORK/table4/results.csv" "$OUT/table4.csv"
cp "$WORK/layouts/results.csv" "$OUT/layouts.csv"
cp "$WORK/clusters/results.csv" "$OUT/clusters.csv"
cp "$WORK/splits/results.csv" "$OUT/splits.csv"
cp "$WORK/sun/results.csv" "$OUT/sun.csv"
cp "$WORK/soft/results.csv" "$OUT/soft.csv"
cp "$WORK/soft_sun/results.csv" "$OUT/soft_sun.csv"
cp "$WORK/soft_smoke/results.csv" "$OUT/soft_smoke.csv"
for pair in glass:stained_glass sunm:sun_clouds smoke:smoke_column; do
  run_name=${pair%%:*}; scene_name=${pair#*:}
  cp "$WORK/$run_name/$scene_name.csv" "$WORK/$run_name/$scene_name.png" "$OUT/"
  cp "$WORK/$run_name/results.md" "$OUT/$scene_name.md"
done
# The tables name the temporary output directory: name the report's instead.
for f in "$OUT"/*.md; do sed -i "s|--out $WORK/[a-z0-9]*|--out docs/bench|g" "$f"; done
sed_tables() { sed -e 1d -e "s|--out $WORK/[a-z0-9]*|--out <tmp>|g" "$1"; }
CAST_NAME=$(basename "${CT_CAST%.json}")

# ---- README -------------------------------------------------------------------
COMMIT=$(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)
if [ -n "$(git status --porcelain 2>/dev/null)" ]; then COMMIT="$COMMIT (with uncommitted changes in the working tree)"; fi
CPU=$(lscpu 2>/dev/null | sed -n 's/^Model name:[[:space:]]*//p' | head -1)
CORES=$(nproc)
MEM=$(awk '/MemTotal/ {printf "%.0f GiB", $2 / 1048576}' /proc/meminfo)
GPU="none"
if command -v nvidia-smi >/dev/null 2>&1; then GPU=$(nvidia-smi -L 2>/dev/null | tr '\n' ';' || true); [ -n "$GPU" ] || GPU="none"; fi
OS=$(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME" || uname -sr)
LOAD_END=$(cut -d' ' -f1-3 /proc/loadavg)
MINUTES=$(( ($(date +%s) - START + 59) / 60 ))

fronts() {  # the Pareto lines of a bench log
  sed -n '/Pareto front/,$p' "$1" | sed 's/^/    /'
}

{
  cat <<EOF
# Speed against error: deep shadow maps and their baselines

Regenerate with **\`bash scripts/bench_report.sh\`** (one command: builds \`cdsm\`
in \`build-report/\`, runs the sweeps below, rewrites this directory; about
$MINUTES minutes here). Everything in this directory is written by that script.

| | |
|---|---|
| commit | \`$COMMIT\` |
| date | $(date -u +%Y-%m-%dT%H:%MZ) |
| machine | $CORES cores, ${CPU:-unknown CPU}, $MEM RAM, GPU: $GPU |
| system | $OS |
| load average (1, 5, 15 min) | $LOAD_START at the start, $LOAD_END at the end |
| build | Release, cpu backend, fragments from the exact CPU ray caster (\`--fragments cpu\`) |

**What is measured** (\`cdsm bench --help\`): every configuration renders the
scene's camera view at 240x160, $REPEAT timed runs after one warm-up, each with a
fresh renderer so every map is built, interleaved round-robin over the
configurations of a scene (a changing load hits all of them alike); *time* is the median DSM build + camera
pass (bars in the plots: min-max). Light-view fragment generation is the same
for every method at a resolution and is in the CSVs (\`fragments_ms_median\`).
Error is against the exact reference renderer (shadow rays, no maps) of the same
view, rendered once and cached: transmittance |T - T_ref| at about 20,000
stratified shaded points, weighted by their compositing weight (mean, p99, max,
RMSE), and the image PSNR. Memory is index + nodes + slack + surface tags
(+ blocker pyramids for lights with a size) of the
\`packed\` layout (an AVSM or OSM in a fixed array would reserve N nodes for every
texel). A machine with a load average above its core count gives noisy times:
compare the load line above.

Methods: **dsm** ε-bounded deep shadow maps (the product); **sm** a conventional
shadow map (opaque where the opacity reaches 0.5: a surface's own alpha test, or
the media's accumulated opacity); **osmN** opacity shadow maps (Kim & Neumann
2001) with N uniform slices over each ray's extent through the casters; **avsmN**
AVSM-style maps (Salvi et al. 2010) with at most N nodes, greedy smallest-area
node removal; **domN** deep opacity maps (Yuksel & Keyser 2008), N layers from
each texel's first caster depth, each the map's casters' depth extent / N
thick; **fomN** Fourier opacity maps (Jansen & Bavoil 2010), N real
coefficients a0, a1, b1, a2, … of the absorption over each texel's depth range;
**momN** moment-based transmittance, b0 and N power moments of the
absorbance with the 32-bit bias MBOIT publishes, the shadow taking the lower
bound (moment shadow mapping's convention: light may leak, a caster never
shadows itself); **reference** the reference renderer's own time (exact, no
maps). All maps are built from the same light rays by the same walker and read
by the same lookup (shadows/hd/baselines.h): dom, fom and mom keep a fixed set
of numbers per texel, and their reconstruction is tabulated into nodes at build
time (within 0.001), so their *build* time includes that tabulation and their
*camera* time is a node lookup, not their own reconstruction (see "Every
method" below for what a lookup would cost). Their **memory** is what an
engine would store: texels × (N + 1, N + 2, N + 3) 32-bit floats (the layers
and the first depth; the coefficients or moments and the texel's depth range),
every texel of the map whether a caster covers it or not. The dom, fom, mom,
osm, avsm and sm maps are grey (a coloured caster enters by its channel mean).

Per scene: \`NAME.csv\` (every figure), \`NAME.md\` (the table), \`NAME.png\` (time
and memory against transmittance RMSE, the Pareto fronts marked).

## Default scene (\`content/scenes/default.json\`)

![default](default.png)

Pareto front (time against transmittance RMSE), from the run:

$(fronts "$WORK/default.log")

$(sed 1d "$OUT/default.md")

EOF
  if [ "$CT_NAME" != "$DEF_NAME" ]; then
    cat <<EOF
## CT "virtual X-ray" scene (\`$CT\`)

![$CT_NAME]($CT_NAME.png)

Pareto front (time against transmittance RMSE), from the run:

$(fronts "$WORK/ct.log")

$(sed 1d "$OUT/$CT_NAME.md")

EOF
  fi
  cat <<EOF
## Every method: deep opacity maps, Fourier opacity maps, moments

The default and CT tables above hold every method; here the same sweep of
methods (the DSM at ε = 0.001, 0.01, 0.1; every baseline at N = 4, 8, 16 where
it allows: moments at 4 and 8) on the stained-glass scene (res 256, 512),
\`sun_clouds.json\` (four clustered orthographic maps of 512²) and
\`smoke_column.json\` (smoke only: a noise column over the ground under a
spot light, as in the seed thesis' comparisons; res 256, 512).

**Equal memory.** Per resolution of the DSM at ε = 0.01, its memory M, and for
each other method the configuration of the sweep whose memory is nearest M
(any N, any resolution of the sweep: the dense methods store every texel, so
at equal memory they trade resolution for N), with its memory against M
(\`scripts/plot_bench.py --equal-memory\`):

### Default scene

$("$PY" scripts/plot_bench.py --equal-memory "$OUT/default.csv" --scene default)

### CT "virtual X-ray"

$("$PY" scripts/plot_bench.py --equal-memory "$OUT/$CT_NAME.csv" --scene "$CT_NAME")

### Stained glass

![stained_glass](stained_glass.png)

$("$PY" scripts/plot_bench.py --equal-memory "$OUT/stained_glass.csv" --scene stained_glass)

Pareto front (time against transmittance RMSE), from the run:

$(fronts "$WORK/glass.log")

$(sed 1d "$OUT/stained_glass.md")

### The sun's clouds

![sun_clouds](sun_clouds.png)

$("$PY" scripts/plot_bench.py --equal-memory "$OUT/sun_clouds.csv" --scene sun_clouds)

Pareto front (time against transmittance RMSE), from the run:

$(fronts "$WORK/sunm.log")

$(sed 1d "$OUT/sun_clouds.md")

### Smoke only

![smoke_column](smoke_column.png)

$("$PY" scripts/plot_bench.py --equal-memory "$OUT/smoke_column.csv" --scene smoke_column)

Pareto front (time against transmittance RMSE), from the run:

$(fronts "$WORK/smoke.log")

$(sed 1d "$OUT/smoke_column.md")

### What the data say

$(cat "$ROOT/scripts/bench_comparison.md")

EOF
  cat <<EOF
## Layouts (thesis §4.2): packed, fixed ("3D texture"), chunked

The same maps in the three storage layouts: *fixed* reserves L
node slots per texel (memory = slack where texels need fewer), *chunked* links
chunks of nodes per texel. Raw rows: \`layouts.csv\`.

$(sed_tables "$WORK/layouts/results.md")

## Clusters (thesis §3.4, Alg. 4.2)

At most m clustered maps per light, each res² texels, on the default scene.
Raw rows: \`clusters.csv\`.

$(sed_tables "$WORK/clusters/results.md")

## Parallel-split DSMs (the cascades clustering competes with)

N maps of res² texels along the camera's view (practical split scheme, plus
the whole cone for points beyond the splits), on the sparse scene, beside the
clusters above (\`--methods pssmN\`). Raw rows: \`splits.csv\`.

$(sed_tables "$WORK/splits/results.md")

## The sun: clustered orthographic maps against one map and cascades

\`sun_clouds.json\` (a directional light over a 1.2 km scene: clouds, hills,
chimney smoke, glass near the camera): one orthographic map over every
caster (m = 1), four clustered orthographic maps (m = 4, LiSPSM distances,
windows focused on each cluster's members), and four parallel splits along
the view plus the whole map (pssm4; ignores m). Raw rows: \`sun.csv\`.

$(sed_tables "$WORK/sun/results.md")

## Soft shadows: estimated penumbrae against a fixed-kernel PCF and hard lookups

Lights with a size against the area-sampled reference (256 stratified
shadow rays per lookup over the sphere light's disk or the sun's cone): the
default scene's key spot light as a sphere of radius 0.05, 0.15 and 0.3
(\`default@r…\`), \`sun_glass.json\` with the sun's angular diameter 0.53°
and 2° (\`sun_glass@sun…\`), and the smoke column of \`smoke_gltf.json\`
(a volume; at 96 × 64: its area reference costs about 38 minutes at 240 × 160)
under a spot light of radius 0.15. Per size: the estimated
penumbra (blockers from the map, \`dsm\`), a fixed-kernel PCF of the same
taps (\`fixed_kernel\`: the kernel of a blocker halfway to the light) and the
hard lookup (\`hard\`). For lights with a size *map* is the maps' own error
(the hard lookup's taps against exact rays through them) and *res* the rest
of the total (penumbra estimate, filter and texels together). Raw rows:
\`soft.csv\`, \`soft_sun.csv\`, \`soft_smoke.csv\`.

$(sed_tables "$WORK/soft/results.md")

$(sed_tables "$WORK/soft_sun/results.md")

$(sed_tables "$WORK/soft_smoke/results.md")

What the data say. **Default scene**: at r = 0.15 the estimated penumbra
lowers the transmittance RMSE from 0.0343 (hard) to 0.0305 and lifts the
image from 39.6 to 41.9 dB; at r = 0.3 from 0.0469 to 0.0360 and 37.1 to
42.4 dB; at r = 0.05 the penumbrae are about a texel wide and the two agree
(0.0340 against 0.0338). The fixed kernel is the worst everywhere (RMSE
0.078–0.153): most of this scene's blockers stand near their receivers,
where a kernel sized for a blocker halfway to the light blurs what the
area light keeps sharp — the reason to estimate the blockers. **The sun**
(sun_glass): at 0.53° the penumbrae are a texel or less (0.0097 → 0.0086);
at 2°, 0.0155 → 0.0128 and 45.5 → 50.8 dB. **Smoke** (a volume, r = 0.15):
0.0257 → 0.0240, 42.8 → 43.8 dB. For every size the estimate is on both
Pareto fronts (the maps are the same memory; it is the more accurate) and
the hard lookup on the time front.

Where it loses: on the default scene at r = 0.15 the *interior* points (the
hard lookup's taps agree with the reference within 0.05) reach p99 0.008 /
max 0.19 with the estimate against 0.004 / 0.046 hard: next to a blocker
within a few texels of the receiver the estimate spreads its shadow a texel
or so past the end of the true penumbra (the disk filter's radius plus the
bilinear taps' own texel; \`tests/unit/test_soft_shadows.cpp\` bounds it on a
straight edge: 0.0053). The largest total errors (T max 0.67 at r = 0.15)
are at edges hard and soft share: features thinner than a texel.

Cost, and where it goes: the camera pass at 240 × 160 (r = 0.15) takes 8.7 ms hard,
57.4 ms estimated (6.6×), 307 ms with the fixed kernel (which always
filters). Per lookup (\`build/tests/bench/bench_lookups\`, 4096 ground points
and 4096 smoke samples on the default scene's 512² map, one thread, median
of 3): hard 0.17 µs per surface point and 0.09 µs per volume sample;
estimated 2.8 µs and 2.1 µs; fixed kernel 19.2 µs and 7.3 µs; the blocker
search alone 1.8 µs and 1.6 µs — two thirds to three quarters of the
estimated lookup is its blocker search (up to 49 texel walks, for every
lookup of a light with a size), the filter is cheap on average because most
receivers have no blocker within reach or a radius under half a texel and
skip it. The next step would be a coarser search first (a min/max depth
pyramid of the map says where no blocker can be). Where the forward
renderer marches volumes, its light grids hold the soft transmittance once
per grid voxel (the same \`cdsm.glsl\` lookup), so a march pays a grid fetch
per sample, not 2 µs. No GPU was lent to this session: these are CPU
figures; the smoke rows ran while a test suite ran at low priority beside
them (the configurations interleave, so their ratios hold).

## The paper's Table 4: nodes per texel against ε

Bornik et al. 2012, Table 4 (thesis Table 5.10): average and maximum "layers"
(nodes) per DSM texel on the virtual X-ray scene, 4 x 256² maps. Here: the same
ε on \`$CT\` with at most 4 clusters of 256² texels each (\`--sweep clusters=4
--sweep res=256\`), averages over all texels of all maps. ${CT_NOTE}
Two variants: the scene as checked in (its walls only receive shadows, so most
texels see the volume alone or nothing) and a copy where every object casts
(as in the thesis' system, where the wall behind the volume is in the maps and
adds its step to every texel). Raw rows: \`table4.csv\`.

As checked in (\`$CT_NAME\`):

$("$PY" scripts/plot_bench.py --epsilon-table "$OUT/table4.csv" --scene "$CT_NAME")

Every object casting (\`$CAST_NAME\`):

$("$PY" scripts/plot_bench.py --epsilon-table "$OUT/table4.csv" --scene "$CAST_NAME")

EOF
} > "$OUT/README.md"
echo "== wrote $OUT (README.md, CSVs, plots) in $MINUTES min" >&2
