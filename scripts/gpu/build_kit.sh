#!/usr/bin/env bash
# Builds the GPU kit HERE (docs/gpu.md, "On a GPU machine"): the GPU machine
# only runs it (scripts/gpu/run_kit.sh). It has the NVIDIA driver but no
# network, no Debian -dev packages, and a call carries at most 64 MiB.
#
#   1. two builds with the `gpu` preset's settings (Release, CUDA for sm_90,
#      no OpenVDB loader, no editor, no GLFW: nothing pulls X11 in) and no
#      build RPATH: $CDSM_KIT_BUILD (default build-gpu) for bench_gpu, and
#      the parity build (CDSM_FP_STRICT=ON) $CDSM_KIT_PARITY_BUILD (default
#      build-gpu-parity) for test_cuda_backend, test_gl_interop,
#      test_cuda_faults and the GL suite (test_fragment_raster,
#      test_gl_kit_suite: test_gl_default_scene, test_gl_system and
#      test_gpu_mesh in one binary; run there on NVIDIA's GL);
#   2. the binaries, stripped, into gpu-kit/bin (release) and gpu-kit/bin/parity;
#   3. every shared library they load that is not on the allowed list
#      (glibc, libstdc++, libgcc_s, and the NVIDIA driver's own: libcuda, the
#      glvnd vendor libraries) from its Debian package: `apt-get download`
#      of the installed version, `dpkg -x` into gpu-kit/root (documentation
#      and headers pruned); the .debs stay in build-kit-debs/;
#   4. gpu-kit/manifest.json (commit, source path, builds, packages, the
#      newest glibc/libstdc++ symbol versions the binaries need);
#   5. the check (also run alone: --check DIR): with LD_LIBRARY_PATH at the
#      kit's library folders only, the `ldd` closure of every carried binary
#      and library resolves inside the kit except the allowed list, nothing
#      needs libcudart, and the kit stays <= 48 MiB.
#
# gpu-kit/ is ignored by git; carry it: run(carry: ["gpu-kit"]).
#
# Usage:
#   bash scripts/gpu/build_kit.sh                   # build both, gather, check
#   bash scripts/gpu/build_kit.sh --no-build        # gather from the existing builds, check
#   bash scripts/gpu/build_kit.sh --check DIR       # check a kit folder
#   bash scripts/gpu/build_kit.sh --small DIR EXE.. # a kit of these binaries, libraries copied
#                                                   # from the installed packages (no download), checked
#                                                   # (the CI test of this script: tests/gpu/CMakeLists.txt)
# Environment: CDSM_KIT_DIR (gpu-kit), CDSM_KIT_BUILD, CDSM_KIT_PARITY_BUILD,
#   CDSM_KIT_JOBS (the cores: ptxas peaks at ~0.4 GB per unit), CDSM_KIT_MAX_MIB (48),
#   CDSM_KIT_CMAKE_ARGS (more configure arguments for both builds).
set -euo pipefail
cd "$(dirname "$0")/../.."
src=$PWD
kit=${CDSM_KIT_DIR:-gpu-kit}
release=${CDSM_KIT_BUILD:-build-gpu}
parity=${CDSM_KIT_PARITY_BUILD:-build-gpu-parity}
jobs=${CDSM_KIT_JOBS:-$(nproc 2>/dev/null || echo 2)}
max_mib=${CDSM_KIT_MAX_MIB:-48}
debs=${CDSM_KIT_DEBS:-build-kit-debs}
arch_dir=x86_64-linux-gnu

# Found on the GPU machine itself: the C and C++ runtimes and the driver.
allowed_re='^(linux-vdso\.so|ld-linux-x86-64\.so|libc\.so|libm\.so|libdl\.so|libpthread\.so|librt\.so|libstdc\+\+\.so|libgcc_s\.so|libcuda\.so|libnvidia-[a-z0-9_-]+\.so|lib(EGL|GLX|GLESv1_CM|GLESv2)_nvidia\.so)'

say() { echo "build_kit: $*"; }
die() { echo "build_kit: error: $*" >&2; exit 1; }

kit_lib_path() { echo "$1/root/usr/lib/$arch_dir:$1/root/lib/$arch_dir"; }

# The ELF files of a kit folder: binaries under bin/, shared libraries under root/.
kit_elves() {
  local f
  while IFS= read -r -d '' f; do
    [[ $(head -c 4 "$f" | od -An -c | tr -d ' ') == 177ELF ]] && echo "$f"
  done < <(find "$1/bin" "$1/root" -type f \( -perm -u+x -o -name '*.so*' \) -print0 2>/dev/null)
}

# "name path" per library `ldd` loads for $2 with the kit's library folders
# first ("name not-found" when none); allowed ones are left out.
deps_of() {
  LD_LIBRARY_PATH=$(kit_lib_path "$1") ldd "$2" 2>/dev/null | while read -r name arrow path _; do
    [[ $name == statically || $name == not ]] && continue
    [[ $name =~ $allowed_re || ${name##*/} =~ $allowed_re ]] && continue
    if [[ $arrow == "=>" ]]; then
      [[ $path == not ]] && echo "$name not-found" || echo "$name $path"
    fi
  done
}

# The Debian package that installed library file $1 (merged /usr: try both spellings).
package_of() {
  local f=$1 real p
  real=$(readlink -f "$f")
  for p in "$f" "$real" "/usr${f#/usr}" "${f#/usr}" "/usr${real#/usr}" "${real#/usr}"; do
    dpkg -S "$p" 2>/dev/null | head -1 | cut -d: -f1-2 | sed 's/: .*//' && return 0
  done
  return 1
}

# Unpacks package $2 (name[:arch]) into kit $1: downloaded (the installed
# version when the archive still has it) and `dpkg -x`, or with mode
# `installed` its installed library files copied (the same bytes; no network).
add_package() {
  local k=$1 pkg=$2 mode=$3 ver tmp f deb
  ver=$(dpkg-query -W -f='${Version}' "$pkg")
  if [[ $mode == installed ]]; then
    dpkg -L "$pkg" | while IFS= read -r f; do
      if [[ $f == */lib/* && ( -f $f || -L $f ) && ! -d $f && ${f##*/} == *.so* ]]; then
        mkdir -p "$k/root${f%/*}" && cp -a "$f" "$k/root$f"
      fi
    done
    echo "$pkg=$ver (installed files)" >>"$k/.packages"
    return 0
  fi
  mkdir -p "$debs"
  deb=$(ls "$debs/${pkg%%:*}_${ver//:/%3a}_"*.deb 2>/dev/null | head -1 || true)
  if [[ -z $deb ]]; then
    tmp=$(mktemp -d)
    (cd "$tmp" && { apt-get download -q "$pkg=$ver" >/dev/null 2>&1 || apt-get download -q "$pkg" >/dev/null; }) ||
      die "apt-get download $pkg failed (apt-get update first?)"
    mv "$tmp"/*.deb "$debs/"
    deb=$(ls -t "$debs/${pkg%%:*}_"*.deb | head -1)
    rmdir "$tmp"
  fi
  dpkg -x "$deb" "$k/root"
  echo "$pkg=$(dpkg-deb -f "$deb" Version) ($(basename "$deb"))" >>"$k/.packages"
}

# Adds the packages of every library the kit's ELF files load from outside
# it, until nothing more is missing.
gather_libraries() {
  local k=$1 mode=$2 round name path pkg missing
  mkdir -p "$k/root"
  : >"$k/.packages"
  for round in 1 2 3 4; do
    missing=()
    while read -r name path; do
      [[ $path == not-found ]] && die "$name is needed by the kit but not found on this machine either"
      [[ $(readlink -f "$path") == "$(readlink -f "$k")"/* ]] && continue
      pkg=$(package_of "$path") || die "no Debian package holds $path ($name)"
      [[ " ${missing[*]-} " == *" $pkg "* ]] || missing+=("$pkg")
    done < <(kit_elves "$k" | while read -r f; do deps_of "$k" "$f"; done | sort -u)
    ((${#missing[@]} == 0)) && break
    say "round $round: ${missing[*]}"
    for pkg in "${missing[@]}"; do add_package "$k" "$pkg" "$mode"; done
  done
  rm -rf "$k/root/usr/share" "$k/root/usr/include" "$k/root/usr/lib/$arch_dir/pkgconfig" "$k/root/usr/lib/$arch_dir/cmake"
  find "$k/root" \( -name '*.a' -o -name '*.la' \) -delete
  sort -u "$k/.packages" -o "$k/.packages"
}

# The newest versioned symbol of `prefix` (GLIBC_, GLIBCXX_) any kit ELF needs.
newest_version() {
  local k=$1 prefix=$2
  kit_elves "$k" | while read -r f; do objdump -T "$f" 2>/dev/null; done |
    grep -o "${prefix}[0-9.]*" | sed "s/^$prefix//" | sort -V | tail -1
}

check_kit() {
  local k=$1 fails=0 f name path bytes
  [[ -d $k/bin ]] || die "$k has no bin/"
  local n=0
  while read -r f; do
    n=$((n + 1))
    if readelf -d "$f" 2>/dev/null | grep -q 'NEEDED.*libcudart'; then
      echo "  $f needs libcudart (the CUDA runtime must be linked statically)"
      fails=$((fails + 1))
    fi
    while read -r name path; do
      if [[ $path == not-found ]]; then
        echo "  $f: $name not found"
        fails=$((fails + 1))
      elif [[ $(readlink -f "$path") != "$(readlink -f "$k")"/* ]]; then
        echo "  $f: $name resolves outside the kit: $path"
        fails=$((fails + 1))
      fi
    done < <(deps_of "$k" "$f")
  done < <(kit_elves "$k")
  ((n > 0)) || { echo "  no ELF file in $k"; fails=$((fails + 1)); }
  bytes=$(du -sb "$k" | cut -f1)
  if ((bytes > max_mib * 1024 * 1024)); then
    echo "  $k holds $((bytes / 1024 / 1024)) MiB, more than $max_mib MiB"
    fails=$((fails + 1))
  fi
  if ((fails)); then
    echo "build_kit: check FAILED: $fails problem(s) in $k ($n ELF files)"
    return 1
  fi
  say "check passed: $n ELF files in $k, every library inside it or allowed, no libcudart, $((bytes / 1024)) KiB <= $max_mib MiB"
}

write_manifest() {
  local k=$1 kind=$2
  local commit dirty
  commit=$(git rev-parse HEAD 2>/dev/null || echo unknown)
  dirty=$([[ -n $(git status --porcelain --untracked-files=no 2>/dev/null) ]] && echo true || echo false)
  {
    echo "{"
    echo "  \"kind\": \"$kind\","
    echo "  \"source_dir\": \"$src\","
    echo "  \"commit\": \"$commit\", \"tree_modified\": $dirty,"
    echo "  \"built\": \"$(date -u +%FT%TZ)\","
    echo "  \"builds\": {\"release\": \"$release\", \"parity\": \"$parity\", \"cmake_args\": \"${common_args[*]-} ${extra[*]-}\"},"
    echo "  \"binaries\": ["
    (cd "$k" && find bin -type f | sort | sed 's/.*/    "&"/; $!s/$/,/')
    echo "  ],"
    echo "  \"packages\": ["
    sed 's/"/\\"/g; s/.*/    "&"/; $!s/$/,/' "$k/.packages"
    echo "  ],"
    echo "  \"needs_glibc\": \"$(newest_version "$k" GLIBC_)\", \"needs_glibcxx\": \"$(newest_version "$k" GLIBCXX_)\","
    echo "  \"lib_path\": [\"root/usr/lib/$arch_dir\", \"root/lib/$arch_dir\"]"
    echo "}"
  } >"$k/manifest.json"
  rm -f "$k/.packages"
}

case "${1:-}" in
  --check)
    [[ $# -eq 2 ]] || die "usage: --check DIR"
    check_kit "$2"
    exit $?
    ;;
  --small)
    [[ $# -ge 3 ]] || die "usage: --small DIR EXE..."
    k=$2
    shift 2
    rm -rf "$k"
    mkdir -p "$k/bin"
    for e in "$@"; do
      cp "$e" "$k/bin/"
      strip --strip-unneeded "$k/bin/$(basename "$e")"
    done
    gather_libraries "$k" installed
    common_args=()
    write_manifest "$k" small
    check_kit "$k"
    exit $?
    ;;
  "" | --no-build) ;;
  *) die "unknown argument $1 (see the header of $0)" ;;
esac

# ---- the two builds -----------------------------------------------------------
common_args=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DCDSM_CUDA=ON -DCMAKE_CUDA_COMPILER=/usr/local/cuda/bin/nvcc
  -DCMAKE_CUDA_ARCHITECTURES=90 -DCDSM_VDB=OFF -DCDSM_EDITOR=OFF -DCDSM_EXAMPLES=OFF -DCDSM_GL=ON -DCDSM_TESTS=ON
  -DCMAKE_DISABLE_FIND_PACKAGE_glfw3=ON -DCMAKE_SKIP_BUILD_RPATH=ON)
# shellcheck disable=SC2206
extra=(${CDSM_KIT_CMAKE_ARGS:-})
# The GL suite, run there on the device's own OpenGL (run_kit.sh stage `gl`):
# the rasterizer against the CPU ray caster, the default scene through GL,
# the system on an application context, meshes that stay on the GPU (the
# last three in one binary, test_gl_kit_suite: each engine binary carries the
# CUDA kernels).
gl_tests=(test_fragment_raster test_gl_kit_suite)
if [[ ${1:-} != --no-build ]]; then
  start=$SECONDS
  for b in "$release" "$parity"; do
    strict=OFF
    targets=(bench_gpu bench_warm)
    if [[ $b == "$parity" ]]; then
      strict=ON
      targets=(test_cuda_backend test_gl_interop test_cuda_faults "${gl_tests[@]}")
    fi
    say "configure $b (CDSM_FP_STRICT=$strict)"
    mkdir -p "$b"
    cmake -S . -B "$b" "${common_args[@]}" -DCDSM_FP_STRICT=$strict "${extra[@]}" >"$b/kit-configure.log" 2>&1 ||
      { tail -30 "$b/kit-configure.log"; die "configure $b failed ($b/kit-configure.log)"; }
    say "build $b: ${targets[*]} (-j $jobs)"
    cmake --build "$b" -j "$jobs" --target "${targets[@]}" ||
      die "build $b failed"
  done
  say "builds took $((SECONDS - start)) s"
fi

# ---- the kit folder -------------------------------------------------------------
[[ -x $release/tests/gpu/bench_gpu ]] || die "$release/tests/gpu/bench_gpu missing: build first"
for t in test_cuda_backend test_gl_interop test_cuda_faults; do
  [[ -x $parity/tests/gpu/$t ]] || die "$parity/tests/gpu/$t missing: build first (test_gl_interop needs GL headers)"
done
rm -rf "$kit"
mkdir -p "$kit/bin/parity"
cp "$release/tests/gpu/bench_gpu" "$release/tests/gl/bench_warm" "$kit/bin/"
cp "$parity/tests/gpu/test_cuda_backend" "$parity/tests/gpu/test_gl_interop" "$parity/tests/gpu/test_cuda_faults" "$kit/bin/parity/"
for t in "${gl_tests[@]}"; do
  [[ -x $parity/tests/gl/$t ]] || die "$parity/tests/gl/$t missing: build first"
  cp "$parity/tests/gl/$t" "$kit/bin/parity/"
done
# The shared data test_gl_system reads (primitives.json's glTF: $SHARED/ is
# $CDSM_DATA_DIR, which run_kit.sh points here): it does not travel otherwise.
data_src=${CDSM_DATA_DIR:-$src/../shared/data}
for f in mesh/vsa_primitives_scene.gltf; do
  [[ -f $data_src/$f ]] || die "$data_src/$f missing: test_gl_system reads it (set CDSM_DATA_DIR)"
  mkdir -p "$kit/data/$(dirname "$f")"
  cp "$data_src/$f" "$kit/data/$f"
done
strip --strip-unneeded "$kit/bin/bench_gpu" "$kit/bin/bench_warm" "$kit/bin/parity/"*
gather_libraries "$kit" download
write_manifest "$kit" device
say "kit: $(find "$kit" -type f | wc -l) files, $(du -sh "$kit" | cut -f1)"
(cd "$kit" && find . -type f -printf '%s\t%p\n' | sort -k2 | awk -F'\t' '{printf "  %8.1f KiB  %s\n", $1 / 1024, $2}')
check_kit "$kit"
