#!/usr/bin/env bash
# prism-render's command line: bad input gives one line on stderr and exit
# code 2; a small render writes every requested format and a summary line.
# Usage: prism_render_cli_test.sh PATH/TO/prism-render TMPDIR
set -u
bin="$1"; tmp="$2"; mkdir -p "$tmp"
fails=0
expect_error() {
  local err rc
  err=$("$bin" "$@" 2>&1 >/dev/null); rc=$?
  if [ "$rc" != 2 ]; then echo "FAIL: '$*' exited $rc, expected 2"; fails=$((fails+1)); return; fi
  if [ "$(printf '%s\n' "$err" | wc -l)" != 1 ] || ! printf '%s' "$err" | grep -q '^prism-render: error: '; then
    echo "FAIL: '$*' did not print one error line: $err"; fails=$((fails+1)); return
  fi
  echo "ok: '$*' -> $err"
}
expect_error --width 0
expect_error --height -5
expect_error --spp 0
expect_error --spp -1
expect_error --threads -1
expect_error --integrator nope
expect_error --filter nope
expect_error --bogus-option
expect_error --out /nonexistent-dir/x.png
expect_error --out "$tmp/x.jpg"
expect_error --out "$tmp"
expect_error --spectral --rgb
expect_error --sampler nope
expect_error --aperture -1
expect_error --focus-distance 0
expect_error --tonemap nope
expect_error --shutter -1
expect_error --aov --out "$tmp/aov.png"
expect_error --shutter nan
expect_error --time inf --shutter 1
expect_error --light-sampler nope
expect_error --instantiation nope
expect_error --default-scene nope
expect_error --texture-filter nope
expect_error --deformation-keys 1
# glTF scenes: a one-triangle file written here, and broken ones.
tri="$tmp/tri.gltf"
cat > "$tri" <<'JSON'
{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
 "bufferViews":[{"buffer":0,"byteLength":36}],
 "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}
JSON
sed 's/"count":3/"count":4/' "$tri" > "$tmp/tri_bad_count.gltf"
printf 'not json at all' > "$tmp/garbage.gltf"
expect_error "$tmp/does_not_exist.gltf"
expect_error "$tmp/garbage.gltf"
expect_error "$tmp/tri_bad_count.gltf"
expect_error "$tri" --camera 3
expect_error "$tri" --env "$tmp/missing.hdr"
expect_error --env "$tmp/missing.hdr"
err=$("$bin" "$tmp/tri_bad_count.gltf" 2>&1 >/dev/null)
if ! printf '%s' "$err" | grep -q 'tri_bad_count.gltf' || ! printf '%s' "$err" | grep -q 'accessors\['; then
  echo "FAIL: the bad accessor error does not name the file and the element: $err"; fails=$((fails+1))
fi
out=$("$bin" "$tri" --width 16 --height 16 --spp 2 --out "$tmp/tri.pfm" -q 2>/dev/null); rc=$?
if [ "$rc" != 0 ] || [ ! -s "$tmp/tri.pfm" ]; then echo "FAIL: the one-triangle glTF did not render ($rc)"; fails=$((fails+1));
else echo "ok: one-triangle glTF renders: $out"; fi

chmod 500 "$tmp" 2>/dev/null
if [ "$(id -u)" != 0 ]; then expect_error --out "$tmp/ro.png"; fi
chmod 700 "$tmp"

rm -f "$tmp"/cli.png "$tmp"/cli.exr "$tmp"/cli.pfm
out=$("$bin" --width 24 --height 16 --spp 2 --out "$tmp/cli.png" --out "$tmp/cli.exr" --out "$tmp/cli.pfm" 2>/dev/null); rc=$?
if [ "$rc" != 0 ]; then echo "FAIL: small render exited $rc"; fails=$((fails+1)); fi
for f in cli.png cli.exr cli.pfm; do
  [ -s "$tmp/$f" ] || { echo "FAIL: $f not written"; fails=$((fails+1)); }
done
printf '%s\n' "$out" | grep -Eq 'samples/s.*rays/s.*[0-9]+ dropped' || { echo "FAIL: no summary line: $out"; fails=$((fails+1)); }
"$bin" --help | grep -q -- '--spp' || { echo "FAIL: --help lists no --spp"; fails=$((fails+1)); }

# The colour model: the default scene disperses, so it renders spectrally
# unless --rgb is given; the summary names the model.
for args in "" "--rgb" "--spectral"; do
  case "$args" in --rgb) want=rgb ;; *) want=spectral ;; esac
  out=$("$bin" --width 8 --height 8 --spp 1 --quiet $args --out "$tmp/model.png" 2>/dev/null)
  printf '%s\n' "$out" | grep -q ", $want, " || { echo "FAIL: '$args' did not render $want: $out"; fails=$((fails+1)); }
done

# Motion blur: the default scene's box moves while the shutter is open; the
# summary says so, and a closed shutter renders the still scene bit for bit.
out=$("$bin" --width 16 --height 16 --spp 2 --rgb --quiet --shutter 1 --out "$tmp/blur.pfm" 2>/dev/null); rc=$?
if [ "$rc" != 0 ] || ! printf '%s
' "$out" | grep -q 'shutter \[0, 1\]'; then
  echo "FAIL: --shutter 1 did not render with motion blur ($rc): $out"; fails=$((fails+1))
else echo "ok: --shutter 1: $out"; fi
"$bin" --width 16 --height 16 --spp 2 --rgb --quiet --out "$tmp/still_a.pfm" >/dev/null 2>&1
"$bin" --width 16 --height 16 --spp 2 --rgb --quiet --shutter 0 --out "$tmp/still_b.pfm" >/dev/null 2>&1
cmp -s "$tmp/still_a.pfm" "$tmp/still_b.pfm" || { echo "FAIL: --shutter 0 differs from no shutter"; fails=$((fails+1)); }
cmp -s "$tmp/still_a.pfm" "$tmp/blur.pfm" && { echo "FAIL: --shutter 1 rendered the still image"; fails=$((fails+1)); }

# AOVs: an EXR with the extra layers, and the PNG beside it unchanged.
out=$("$bin" --width 16 --height 16 --spp 2 --rgb --quiet --aov --out "$tmp/aov.exr" --out "$tmp/aov.pfm" 2>/dev/null); rc=$?
if [ "$rc" != 0 ] || [ ! -s "$tmp/aov.exr" ] || ! grep -aq 'albedo.R' "$tmp/aov.exr" || ! grep -aq 'variance.B' "$tmp/aov.exr"; then
  echo "FAIL: --aov did not write the EXR layers ($rc)"; fails=$((fails+1))
else echo "ok: --aov writes albedo, N, Z and variance layers"; fi
cmp -s "$tmp/aov.pfm" "$tmp/still_a.pfm" || { echo "FAIL: --aov changed the image"; fails=$((fails+1)); }

# Light selection: each choice renders and the summary names it; auto picks
# power for the default scene's few lights.
for ls in auto power uniform bvh; do
  case "$ls" in auto) want="power light selection (auto)" ;; *) want="$ls light selection" ;; esac
  out=$("$bin" --width 12 --height 12 --spp 2 --rgb --quiet --light-sampler $ls --out "$tmp/ls_$ls.pfm" 2>/dev/null); rc=$?
  if [ "$rc" != 0 ] || [ ! -s "$tmp/ls_$ls.pfm" ] || ! printf '%s\n' "$out" | grep -qF "$want"; then
    echo "FAIL: --light-sampler $ls ($rc): $out"; fails=$((fails+1))
  else echo "ok: --light-sampler $ls: $want"; fi
done
out=$("$bin" "$tri" --width 8 --height 8 --spp 1 --quiet --light-sampler bvh --out "$tmp/tri_bvh.pfm" 2>/dev/null); rc=$?
if [ "$rc" != 0 ] || ! printf '%s\n' "$out" | grep -qF "bvh light selection"; then
  echo "FAIL: a glTF scene with --light-sampler bvh ($rc): $out"; fails=$((fails+1))
else echo "ok: glTF with --light-sampler bvh"; fi
# Texture filtering: every filter renders a glTF file; one without textures
# renders the same image with each, bit for bit.
for tf in point bilinear trilinear ewa; do
  "$bin" "$tri" --width 8 --height 8 --spp 1 --quiet --texture-filter $tf --out "$tmp/tri_tf_$tf.pfm" >/dev/null 2>&1 \
    || { echo "FAIL: --texture-filter $tf did not render"; fails=$((fails+1)); }
  cmp -s "$tmp/tri_tf_$tf.pfm" "$tmp/tri_tf_point.pfm" || { echo "FAIL: --texture-filter $tf changed an untextured image"; fails=$((fails+1)); }
done
echo "ok: --texture-filter point, bilinear, trilinear, ewa"
# The default image with auto selection is the power-selection image, bit for bit.
cmp -s "$tmp/ls_auto.pfm" "$tmp/ls_power.pfm" || { echo "FAIL: auto differs from power on the default scene"; fails=$((fails+1)); }

# Instantiations (docs/instantiation.md): the summary names the one picked;
# the diffuse box takes the diffuse set, the default scene and a forced run
# the full one, a glTF file the metal_rough one; minimal and full render the
# diffuse box bit for bit alike.
check_inst() {  # want, then the arguments
  local want="$1"; shift
  out=$("$bin" --width 12 --height 12 --spp 2 --quiet "$@" 2>/dev/null); rc=$?
  if [ "$rc" != 0 ] || ! printf '%s\n' "$out" | grep -qF "instantiation: $want"; then
    echo "FAIL: '$*' did not pick '$want' ($rc): $out"; fails=$((fails+1))
  else echo "ok: '$*' -> $want"; fi
}
check_inst "rgb, bxdfs {diffuse} (diffuse)" --default-scene cornell-diffuse --out "$tmp/inst_min.pfm"
check_inst "rgb, bxdfs {diffuse, dielectric, conductor, thin_dielectric, metal_rough} (full)" \
  --default-scene cornell-diffuse --instantiation full --out "$tmp/inst_full.pfm"
check_inst "spectral, bxdfs {diffuse} (diffuse)" --default-scene cornell-diffuse --spectral --out "$tmp/inst_s.pfm"
check_inst "spectral, bxdfs {diffuse, dielectric, conductor, thin_dielectric, metal_rough} (full)" --out "$tmp/inst_d.pfm"
check_inst "rgb, bxdfs {metal_rough} (metal_rough)" "$tri" --out "$tmp/inst_tri.pfm"
check_inst "rgb, bxdfs {diffuse, dielectric, conductor, thin_dielectric, metal_rough} (full)" "$tri" \
  --instantiation full --out "$tmp/inst_tri_full.pfm"
# A dispersive glTF volume (KHR_materials_dispersion, a glass box built by
# tests/gltf/volume_test.cpp) renders spectrally unless --rgb is asked for.
disp="$(dirname "${BASH_SOURCE[0]}")/dispersive_box.gltf"
check_inst "spectral, bxdfs {metal_rough} (metal_rough)" "$disp" --out "$tmp/inst_disp.pfm"
check_inst "rgb, bxdfs {metal_rough} (metal_rough)" "$disp" --rgb --out "$tmp/inst_disp_rgb.pfm"
cmp -s "$tmp/inst_min.pfm" "$tmp/inst_full.pfm" || { echo "FAIL: minimal and full differ on the diffuse box"; fails=$((fails+1)); }
cmp -s "$tmp/inst_tri.pfm" "$tmp/inst_tri_full.pfm" || { echo "FAIL: metal_rough and full differ on a glTF file"; fails=$((fails+1)); }

# Spatial splits change the BVH, not what a ray hits: the same image.
out=$("$bin" --width 16 --height 16 --spp 2 --rgb --quiet --spatial-splits --out "$tmp/sbvh.pfm" 2>/dev/null); rc=$?
if [ "$rc" != 0 ] || ! cmp -s "$tmp/sbvh.pfm" "$tmp/still_a.pfm"; then
  echo "FAIL: --spatial-splits did not render the image without them ($rc): $out"; fails=$((fails+1))
else echo "ok: --spatial-splits renders the same image"; fi

# The fallback environment: only for a scene with no light of any kind. A
# scene lit by its own emitters (an open emissive triangle, a closed emissive
# tetrahedron) gets none: no message, no environment among its lights, and
# the open scene's background is black. --env none turns the fallback off.
emis="$tmp/tri_emissive.gltf"
sed 's/"meshes":\[{"primitives":\[{"attributes":{"POSITION":0}}\]}\]/"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],"materials":[{"emissiveFactor":[1,1,1]}]/' "$tri" > "$emis"
tet="$tmp/tet_emissive.gltf"
cat > "$tet" <<'JSON'
{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],
 "materials":[{"emissiveFactor":[1,0.5,0.25]}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]},
              {"bufferView":1,"componentType":5123,"count":12,"type":"SCALAR"}],
 "bufferViews":[{"buffer":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":24}],
 "buffers":[{"byteLength":72,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAACAAEAAAABAAMAAAADAAIAAQACAAMA"}]}
JSON
pfm_corners() {  # prints the largest value of the four corner pixels
  python3 - "$1" <<'PY'
import struct, sys
d = open(sys.argv[1], 'rb').read()
parts = d.split(b'\n', 3)
w, h = map(int, parts[1].split()); px = parts[3]
fmt = '<' if float(parts[2]) < 0 else '>'
def at(x, y): return struct.unpack_from(fmt + '3f', px, 12 * (y * w + x))
print(max(max(at(x, y)) for x in (0, w - 1) for y in (0, h - 1)))
PY
}
check_no_env() {  # name, file, extra arguments
  local name="$1" file="$2"; shift 2
  local err out rc
  err=$("$bin" "$file" --width 16 --height 16 --spp 2 --out "$tmp/$name.pfm" "$@" 2>&1 >"$tmp/$name.out"); rc=$?
  out=$(cat "$tmp/$name.out")
  if [ "$rc" != 0 ] || printf '%s' "$err" | grep -q 'white environment' || printf '%s' "$out" | grep -q 'environment}' ||
     printf '%s' "$out" | grep -q 'environment,'; then
    echo "FAIL: $name: an environment was added ($rc): $err $out"; fails=$((fails+1))
  else echo "ok: $name: no environment"; fi
}
check_no_env open_emissive "$emis"
check_no_env closed_emissive "$tet"
check_no_env env_none "$tri" --env none
c=$(pfm_corners "$tmp/open_emissive.pfm")
[ "$c" = "0.0" ] || { echo "FAIL: the open emissive scene's background is $c, not black"; fails=$((fails+1)); }
err=$("$bin" "$tri" --width 8 --height 8 --spp 1 --out "$tmp/tri_env.pfm" 2>&1 >/dev/null)
printf '%s' "$err" | grep -q 'adding a white environment' ||
  { echo "FAIL: a scene without any light got no fallback environment: $err"; fails=$((fails+1)); }
c=$(pfm_corners "$tmp/tri_env.pfm")
[ "$c" != "0.0" ] || { echo "FAIL: the fallback environment left the background black"; fails=$((fails+1)); }

if [ "$fails" != 0 ]; then echo "$fails failures"; exit 1; fi
echo "all prism-render CLI checks passed"
