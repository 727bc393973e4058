#!/usr/bin/env bash
# Mutation testing of prism's physics: each mutant below is a deliberate
# one-line change to the model (a separable Smith G, a missing cosine, a pdf
# off by a factor, ...). Each is applied alone to a copy of the tree, the
# test executables of its ctest labels are built, and their tests run; a
# mutant is KILLED when a test fails, SURVIVED when all pass. A good suite
# kills every one. docs/testing.md lists them and what kills each.
#
# Usage: scripts/mutants.sh [--tree DIR] [--work DIR] [--only ID[,ID...]] [--all-labels]
#   --tree DIR    the source tree to mutate (default: this checkout)
#   --work DIR    where the copy and its build live (default: /tmp/prism-mutants)
#   --only IDS    run only these mutants (comma-separated ids)
#   --no-baseline skip the unmutated check (another run did it)
#   --check       only check that every pattern applies (no build)
#   --all-labels  run every label of a mutant even after one has killed it
#                 (default: stop at the first; labels are listed cheapest first)
# A label whose executable the tree does not have (an older tree without
# tests/reference) is skipped. Each label is first built and tested on the
# unmutated copy (the first time a mutant needs it): if that fails, the run
# stops. Exits non-zero if any mutant survives, a
# pattern does not match exactly once in its file, or a mutant does not
# compile. Prints per mutant KILLED / SURVIVED, the time taken, and a score.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tree="$root"
work="${TMPDIR:-/tmp}/prism-mutants"
only=""
all_labels=0
check=0
no_baseline=0
while (($#)); do
  case "$1" in
    --tree) tree="$(cd "$2" && pwd)"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    --only) only=",$2,"; shift 2 ;;
    --all-labels) all_labels=1; shift ;;
    --check) check=1; shift ;;
    --no-baseline) no_baseline=1; shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
done

# id | file | exact text (must occur once) | replacement | labels (cheapest first)
# Fields are separated by ' | '; the texts are literal (no regex).
mutants=$(cat <<'EOF'
separable_G | include/prism/bxdfs/microfacet.hpp | { return 1 / (1 + lambda(wo) + lambda(wi)); } | { return G1(wo) * G1(wi); } | prism_test_reference prism_test_bxdfs
lambda_half | include/prism/bxdfs/microfacet.hpp | return t / (2 * (std::sqrt(1 + t) + 1)); | return t / (std::sqrt(1 + t) + 1); | prism_test_reference prism_test_bxdfs
lambda_axes_swapped | include/prism/bxdfs/microfacet.hpp | Float t = (sqr(m_ax * w.x) + sqr(m_ay * w.y)) / z2; | Float t = (sqr(m_ay * w.x) + sqr(m_ax * w.y)) / z2; | prism_test_reference prism_test_bxdfs
D_not_squared | include/prism/bxdfs/microfacet.hpp | return 1 / (pi * m_ax * m_ay * s * s); | return 1 / (pi * m_ax * m_ay * s); | prism_test_reference prism_test_bxdfs
vndf_pdf_no_cos | include/prism/bxdfs/microfacet.hpp | return G1(w) / cz * D(wm) * d; | return G1(w) * D(wm) * d; | prism_test_reference prism_test_bxdfs
conductor_missing_cos | include/prism/bxdfs/conductor.hpp | (d * m_distrib.G(wo, wi) / (4 * co * ci)) | (d * m_distrib.G(wo, wi) / (4 * co)) | prism_test_reference prism_test_bxdfs
conductor_pdf_factor | include/prism/bxdfs/conductor.hpp | *pdf = m_distrib.G1(wo) * d / (4 * co); | *pdf = m_distrib.G1(wo) * d / (2 * co); | prism_test_reference prism_test_bxdfs
conductor_fresnel_p_only | include/prism/bxdfs/conductor.hpp | return Float((rp + rs) / 2); | return Float(rp); | prism_test_reference prism_test_bxdfs
fresnel_tir_branch | include/prism/bxdfs/dielectric.hpp | if (!(cos2_t > 0)) return 1;  // total internal reflection | if (!(cos2_t > 0)) return 0;  // total internal reflection | prism_test_reference prism_test_bxdfs
snell_eta_inverted | include/prism/bxdfs/dielectric.hpp | double k = c / e - std::sqrt(cos2_t); | double k = c * e - std::sqrt(cos2_t); | prism_test_reference prism_test_bxdfs
btdf_half_vector | include/prism/bxdfs/dielectric.hpp | Float denom = sqr(dwi + dwo / etap); | Float denom = sqr(dwi + dwo * etap); | prism_test_reference prism_test_bxdfs
btdf_radiance_eta2 | include/prism/bxdfs/dielectric.hpp | if (mode == TransportMode::radiance) f /= sqr(etap); | if (mode == TransportMode::radiance) f *= sqr(etap); | prism_test_reference prism_test_bxdfs
beer_lambert_half | include/prism/bxdfs/volume.hpp | std::exp(-sigma[i] * t); | std::exp(-sigma[i] * t / 2); | prism_test_reference prism_test_bxdfs
schlick_complement | include/prism/bxdfs/metal_rough.hpp | (10 + c * (-5 + c)) | (10 + c * (-4 + c)) | prism_test_reference prism_test_bxdfs
anisotropy_linear | include/prism/bxdfs/metal_rough.hpp | TrowbridgeReitz(alpha + (1 - alpha) * sqr(p.anisotropy), alpha) | TrowbridgeReitz(alpha + (1 - alpha) * p.anisotropy, alpha) | prism_test_bxdfs
clearcoat_once | include/prism/bxdfs/metal_rough.hpp | return inner_eval(wo, wi, mode) * (c.t_o * c.t_i) + S(c.f); | return inner_eval(wo, wi, mode) * c.t_o + S(c.f); | prism_test_bxdfs
sheen_scale_min | include/prism/bxdfs/metal_rough.hpp | std::min(std::max(e_o, e_i), Float(1)) | std::min(std::min(e_o, e_i), Float(1)) | prism_test_bxdfs
charlie_D_power | include/prism/bxdfs/sheen.hpp | std::pow(sin2, Float(0.5) * inv) | std::pow(sin2, inv) | prism_test_bxdfs
thin_film_phase | include/prism/bxdfs/thin_film.hpp | (4 * 3.14159265358979323846 * n2 | (2 * 3.14159265358979323846 * n2 | prism_test_bxdfs
skin_no_inverse_bind | include/prism/io/gltf/deform.hpp | out[j] = world(skin.joints[j]) * inv_bind; | out[j] = world(skin.joints[j]); | prism_test_gltf
skin_weights_unnormalised | include/prism/io/gltf/deform.hpp | double w = std::max(sets[s].second[4 * i + c], 0.0) / sum; | double w = std::max(sets[s].second[4 * i + c], 0.0); | prism_test_gltf
deform_blend_eased | include/prism/accel/deforming_mesh.hpp | out->v[r][l] = p.a.v[r][l] + f * p.d.v[r][l]; | out->v[r][l] = p.a.v[r][l] + f * f * p.d.v[r][l]; | prism_test_accel
kulla_conty_fms | include/prism/bxdfs/ms_compensation.hpp | return fa * fa * e_avg / (1 - fa * (1 - e_avg)); | return fa * e_avg / (1 - fa * (1 - e_avg)); | prism_test_reference prism_test_bxdfs
lambert_no_pi | include/prism/bxdfs/diffuse.hpp | S eval(Vector3f wo, Vector3f wi, TransportMode) const {@@    if (!same_hemisphere(wo, wi)) return S{};@@    return m_r * inv_pi; | S eval(Vector3f wo, Vector3f wi, TransportMode) const {@@    if (!same_hemisphere(wo, wi)) return S{};@@    return m_r; | prism_test_reference prism_test_bxdfs
oren_nayar_A_B_swapped | examples/oren_nayar.hpp | if (s <= 0) return m_a + m_b * s; | if (s <= 0) return m_b + m_a * s; | prism_test_reference prism_test_bxdfs
mis_balance | include/prism/sampling/warps.hpp | Float f = f_pdf * f_pdf, g = g_pdf * g_pdf; | Float f = f_pdf, g = g_pdf; | prism_test_reference prism_test_sampling
cosine_pdf_factor | include/prism/sampling/warps.hpp | return cos_theta > 0 ? cos_theta * inv_pi : 0; | return cos_theta > 0 ? cos_theta * inv_2pi : 0; | prism_test_reference prism_test_sampling
offset_ignores_error | include/prism/geometry/ray.hpp | Float d = dot(abs(n), p_error); | Float d = 0 * dot(abs(n), p_error); | prism_test_reference prism_test_geometry
cmf_index | include/prism/spectra/spectrum.hpp | int i = std::min(int(x), data::cie_samples - 2); | int i = std::min(int(x) + 1, data::cie_samples - 2); | prism_test_reference prism_test_spectra
sellmeier_sign | include/prism/spectra/dispersion.hpp | n2 += m_B[size_t(i)] * l2 / (l2 - m_C[size_t(i)]); | n2 += m_B[size_t(i)] * l2 / (l2 + m_C[size_t(i)]); | prism_test_reference prism_test_spectra
planck_sign | include/prism/spectra/spectrum.hpp | (std::exp(h * c / (l * kb * T)) - 1) | (std::exp(h * c / (l * kb * T)) + 1) | prism_test_reference prism_test_spectra
EOF
)
# '@@' in a text stands for a newline (a pattern spanning lines, to anchor a
# line that occurs more than once in its file).

src="$work/src"
build="$work/build"
mkdir -p "$work"
echo "mutants: copying $tree to $src"
rm -rf "$src"
mkdir -p "$src"
# -m: every file new, so that the build sees whatever changed since a last run.
tar -C "$tree" --exclude=./build --exclude=./.git -cf - . | tar -C "$src" -m -xf -
# Sources whose mtime the build must see change: restore from the tree.
restore() { cp -p "$tree/$1" "$src/$1"; touch "$src/$1"; }

# Replace the single occurrence of $2 by $3 in file $1; exit 3 if $2 does
# not occur exactly once.
apply() {
  perl -e '
    my ($f, $from, $to) = @ARGV;
    s/\@\@/\n/g for ($from, $to);
    local $/; open(my $in, "<", $f) or die "$f: $!"; my $s = <$in>; close $in;
    my $n = () = $s =~ /\Q$from\E/g;
    exit 3 if $n != 1;
    $s =~ s/\Q$from\E/$to/;
    open(my $out, ">", $f) or die "$f: $!"; print $out $s; close $out;' "$@"
}

if [ "$check" = 1 ]; then
  bad=0
  while IFS= read -r line; do
    [ -z "$line" ] && continue
    IFS='|' read -r id file from to labels <<<"${line// | /|}"
    if apply "$src/$file" "$from" "$to"; then echo "applies: $id"; else echo "NOT APPLIED: $id ($file)"; bad=1; fi
    restore "$file"
  done <<<"$mutants"
  exit $bad
fi

if [ ! -f "$build/build.ninja" ]; then
  cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" \
    -DPRISM_BUILD_BENCH=OFF -DPRISM_WERROR=OFF -DPRISM_TEST_UNITY=ON >"$work/configure.log" 2>&1 ||
    { echo "configure failed: $work/configure.log"; exit 1; }
fi
has_target() { ninja -C "$build" -t query "$1" >/dev/null 2>&1; }
build_label() { cmake --build "$build" --target "$1" -j 2 >"$work/build-$1.log" 2>&1; }
run_label() { (cd "$build" && ctest -L "^$1\$" -j 2 --timeout 600 >"$work/test-$1.log" 2>&1); }

# The unmutated tree must pass every label used: checked the first time a
# label is needed (a label that the cheaper ones make unnecessary is never
# built). $1: the label; $2: the file the current mutant changed, restored
# for the check and mutated again after it (apply's arguments follow).
declare -A baseline=()
ensure_baseline() {
  local l="$1" file="$2"
  [ -n "${baseline[$l]:-}" ] || [ "$no_baseline" = 1 ] && return 0
  shift 2
  restore "$file"
  local t0=$SECONDS
  build_label "$l" || { echo "baseline: $l does not build ($work/build-$l.log)"; exit 1; }
  run_label "$l" || { echo "baseline: $l fails unmutated ($work/test-$l.log)"; exit 1; }
  echo "baseline: $l passes unmutated ($((SECONDS - t0)) s)"
  baseline[$l]=1
  apply "$src/$file" "$@"
}

killed=0 survived=0 broken=0 total=0
start=$SECONDS
while IFS= read -r line; do
  [ -z "$line" ] && continue
  IFS='|' read -r id file from to labels <<<"${line// | /|}"
  if [ -n "$only" ] && [[ "$only" != *",$id,"* ]]; then continue; fi
  total=$((total + 1))
  t0=$SECONDS
  status=SURVIVED
  by=""
  if ! apply "$src/$file" "$from" "$to"; then
    status="NOT APPLIED (pattern not found exactly once in $file)"
  else
    for l in $labels; do
      has_target "$l" || continue
      ensure_baseline "$l" "$file" "$from" "$to"
      if ! build_label "$l"; then
        status="DOES NOT BUILD ($work/build-$l.log)"
        break
      fi
      if ! run_label "$l"; then
        status=KILLED
        by="$by $l"
        cp "$work/test-$l.log" "$work/killed-$id-$l.log"
        [ "$all_labels" = 1 ] || break
      fi
    done
  fi
  restore "$file"
  case "$status" in
    KILLED) killed=$((killed + 1)) ;;
    SURVIVED) survived=$((survived + 1)) ;;
    *) broken=$((broken + 1)) ;;
  esac
  msg=$(printf '%-24s %-9s %4d s%s' "$id" "${status%% (*}" $((SECONDS - t0)) "${by:+  by$by}")
  [ "${status%% (*}" = "$status" ] || msg="$msg  ${status#* (}"
  echo "$msg"
done <<<"$mutants"
echo
echo "score: $killed / $total killed, $survived survived, $broken not applied or not built ($((SECONDS - start)) s)"
[ "$survived" = 0 ] && [ "$broken" = 0 ]
