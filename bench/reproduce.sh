#!/usr/bin/env bash
# Reruns the studies behind the committed results with the current build and writes their
# files under bench/results/ again (bench/results/README.md says which command makes which
# file). Every file it writes gets a row in bench/results/provenance.csv: the file, the
# study, the commit it came from (with "+dirty" when the work tree had changes), the
# machine (CPU model, logical CPUs), and when.
#
#   bench/reproduce.sh [--quick] [--list] [--help] [STUDY ...]
#
# With no STUDY, every study in order. --quick runs the short studies only (about 15
# minutes on 2 cores). The full run is about 7 hours on 2 cores (PoCL; the sum of each
# study's last run, on the machine provenance.csv names for its files, not timed end to
# end); the longest studies are render (about 150 minutes; RENDER_FIBERS="polyester" renders
# one fiber's sky and sky-map configs alone), search_before_after, render_room, search_compare
# and rgb_refine. SAMPLING_PEERS_SAMPLES sets the samples per sampler of sampling_peers
# (default 65536; the CSV's `samples` column says what a run used).
# Run from the repository root after scripts/setup, whose build has the peers the em study
# runs (BSDFMIX_BUILD_BENCH, on by default; a build-bench/ build is used when present).
#
# The search_before_after and search_unseen studies compare this build with another: set
# BEFORE to that build's bsdfmix (they are skipped otherwise); search_unseen also needs
# RGL_DIR, a folder of RGL material files (*_rgb.bsdf) beyond those data/rgl/ ships.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/bsdfmix
py=/usr/bin/python3
results=bench/results
provenance=$results/provenance.csv

# name : minutes on 2 cores : quick? : what
studies=(
  "rgb_stand_in:8:quick:the chromatic stand-in on the RGL materials and fiber presets, with and without colour copies (rgb_stand_in.csv, rgb_stand_in_no_copies.csv)"
  "rgb_refine:25:no:the channels in the L1 refinement, variant by variant, against the luminance alone (rgb_refine.csv)"
  "quickstart:2:quick:the quickstart from a clean out/quickstart/ and its summary figure (docs/images/quickstart.png)"
  "stand_in_bytes:5:quick:bytes against error (stand_in_bytes.csv, docs/images/stand_in_bytes.png)"
  "standin_targets:20:no:bsdfmix standin at a 5% median RGB error on the four RGL files and the four presets at 30 rows, four at 45, paper_white at 90 (standin_targets*.csv)"
  "compact_rivals:30:no:the stand-in against a smaller table and spherical harmonics at 2 to 32 KiB, per slice on the fiber presets and the RGL materials, and in the image (compact_rivals.csv, compact_rivals_image.csv, docs/images/compact_rivals.png)"
  "render_rgl:5:quick:the RGL materials on a sphere under the sky map, and the small polyester render, satin and polyester fitted closer too (render/*_skymap*/, render/polyester_sky_small*/)"
  "search_before_after:31:no:the walk of this build against BEFORE's, with this build's colour work off too (search_before_after.csv, search_before_after_chi_square.csv)"
  "search_time:18:no:the thesis-scale polyester sweep by this build and BEFORE's, best of 3 (search_time.csv)"
  "search_unseen:3:no:the walk of this build against BEFORE's on RGL materials not shipped, from RGL_DIR (search_unseen.csv)"
  "pinned_k:2:no:satin's grazing slices fitted by the default search and at pinned K 8, 16, 32 (pinned_k.csv)"
  "tails:4:no:satin's grazing slices by plain EM with Gaussians and with Student-t components of 3 and 10 degrees of freedom (tails.csv)"
  "map_choice:30:no:fit.map auto against theta_phi and equal_area: default fits of the four RGL files at 90 x 90 x 180, the map auto chose, its probe's cost, L1 and K (map_choice.csv)"
  "map_accuracy:12:no:the equal-area map with its base against (theta, phi) on the RGL files and the fiber presets (map_accuracy.csv)"
  "renderer_chi2:15:no:Mitsuba 3's chi-square test on equal-area and (theta, phi) fits of the RGL files and the presets (renderer_chi2.csv, renderer_chi2_theta_phi.csv)"
  "parameterization:15:no:the pole and the border: plain EM in three parameterizations of the hemisphere against the project's fits (parameterization.csv)"
  "search_compare:26:no:the Gaussian-count search methods, and the refinement's chi-square on the RGL rows (search_compare*.csv, search_chi_square.csv, docs/images/search_l1_vs_k.png)"
  "fit_sweep:10:no:thesis-scale silk and polyester sweeps, best of 3 (fit_sweep.csv)"
  "catalog:1:no:the catalog job (catalog_summary.csv)"
  "scale:15:no:the MPI farm (scale_<machine>.csv)"
  "converge:4:no:the convergence studies under constant light (converge/)"
  "converge_refine:1:no:satin's importance sampling by the refined and by EM's mixtures (converge_refine/)"
  "converge_light:10:no:the convergence studies with the lighting (converge_light/)"
  "mis_heuristic:10:no:balance against power heuristic (mis_heuristic.csv)"
  "render:150:no:the cloth renders of the four fibers under the sky and the sky map (render/<fiber>_<scene>/)"
  "render_room:30:no:the cloth of the four fibers in the room, the guided estimators against the baseline (render/<fiber>_room/)"
  "em:8:no:the EM benchmark against the peers at K 8, 16 and 50, best of 5 (em_k8_*.csv, em_k16_*.csv, em_k50_*.csv)"
  "em_builds:3:no:EM throughput of this build beside BEFORE's at K 8, 16, 50, best of 5 (em_builds.csv)"
  "em_speed:12:no:the EM and L1 kernels of this build beside BEFORE's: bench em at K 8, 16, 50 and the L1 refinement's CPU time in a silk fit, alternating, best of 5 (em_speed.csv)"
  "house_speed:5:no:EM throughput and the render's ns per vertex of this build beside BEFORE's, alternating, best of 5 (house_speed.csv)"
  "fit_speed:25:no:default fits of the four RGL files by this build and BEFORE's, alternating, best of 3: wall, CPU, utilization, L1, same mixtures (fit_speed.csv)"
  "mixed_devices:6:no:a thesis-length silk sweep on PoCL alone and on PoCL beside oclgrind, best of 3 (mixed_devices.csv)"
  "em_precision:1:no:the EM kernels against their reference, both precisions (em_precision.csv)"
  "theta_border:1:no:known mixtures with a lobe near the theta border, the three search methods (theta_border.csv)"
  "failure_map:1:quick:the failure map over configs/stress/ (failure_map.csv)"
  "render_rays:1:no:primary rays per Embree curve type, one thread (render_rays_*.csv)"
  "fiber_quadrature:1:no:the fiber model's h quadrature against 2048 nodes (fiber_quadrature.csv)"
  "fiber_generate:1:no:the fiber table generator's time and peak memory, the default and the full 4D table (fiber_generate.csv)"
  "cells_scale:120:no:fits of K 8 on wool tables of 10^7 to 10^9 cells: time per cell and peak memory against size, tables kept in out/cells_scale/ (cells_scale.csv, docs/images/cells_scale.png)"
  "rgl_negative:1:no:the RGL files' negative channels kept signed and clipped, the luminance compared (rgl_negative.csv)"
  "rgl_albedo:1:no:the RGL files' albedo on the grid, sampled and converged, and their reciprocity (rgl_albedo.csv)"
  "interpolation:6:no:blend against displace between slices, every other slice of the sampling_peers fits left out (interpolation.csv; runs sampling_peers first when out/sampling_peers/ lacks its fits)"
  "rgl_resolve:60:no:each RGL file at the default grid and at the grid that resolves its narrowest lobe, as a sampler against the file's own at 20 views; satin also with finer grids and more components (rgl_resolve.csv)"
  "render_4d:40:no:the cloth with f from the full-4D wool table, memory-mapped, against its stand-in and the azimuthal table, best of 5 (render_4d.csv; the 4.2 GB table and the fit in out/render_4d/)"
  "render_material:6:no:the glossy RGL spheres with the light-sampling estimators, on the sphere's own pixels, under the sky map with and without the ground and under the analytic sky (render_material.csv)"
  "sampling_peers:60:no:each RGL file's own sampler against the fitted mixture, the table CDF and uniform, with the file's f, under constant light and the sky (with light sampling, MIS and the product), and the fiber presets (sampling_peers.csv)"
  "amplitude_objective:8:no:the stand-in's amplitude objective, three ways (amplitude_objective.csv; runs rgb_stand_in's fits first when out/bench_rgb/ lacks them)"
)

usage() {
  sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  echo
  echo "Studies:"
  for s in "${studies[@]}"; do
    IFS=: read -r name minutes quick what <<<"$s"
    printf "  %-20s %4s min%s  %s\n" "$name" "$minutes" "$([ "$quick" = quick ] && echo ', quick' || echo '       ')" "$what"
  done
}

# The commit, "+dirty" when the code that makes results differs from it (docs do not count)
commit=$(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD -- host kernels include configs data bench scripts CMakeLists.txt ':!bench/results' 2>/dev/null ||
  commit="$commit+dirty"
cpu=$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1 | tr ',' ';')
cores=$(nproc)
# The machine's tag in file names, as bench/render_rays.cpp makes it: "AMD EPYC 7B13 ..." on
# 2 logical CPUs -> amd-epyc-2c (the first two words of the model, lower case, no (R)/(TM)).
machine=$(echo "${cpu:-unknown}" | sed 's/([RrTtMm]*)//g' | awk '{print tolower($1) (NF > 1 ? "-" tolower($2) : "")}')-${cores}c

# Records that `file` was written by `study` now, and takes it off stale.csv (its globs).
record() {
  local file=$1 study=$2
  [ -f "$provenance" ] || echo "file,study,commit,cpu,logical_cpus,utc" > "$provenance"
  grep -v "^$file," "$provenance" > "$provenance.tmp" || true
  echo "$file,$study,$commit,${cpu:-unknown},$cores,$(date -u +%Y-%m-%dT%H:%M:%SZ)" >> "$provenance.tmp"
  mv "$provenance.tmp" "$provenance"
  [ -f "$results/stale.csv" ] && $py - "$results/stale.csv" "${file#$results/}" <<'PY'
import csv, fnmatch, os, sys
path, done = sys.argv[1], sys.argv[2]
with open(path, newline="") as f:
    rows = list(csv.DictReader(f))
keep = [r for r in rows if not fnmatch.fnmatch(done, r["file"])]
if len(keep) != len(rows):
    with open(path + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["file", "why"], lineterminator="\n")
        w.writeheader()
        w.writerows(keep)
    os.replace(path + ".tmp", path)
PY
}
# The files a study writes (globs under the repository root).
outputs() {
  case $1 in
    rgb_stand_in) echo "$results/rgb_stand_in.csv $results/rgb_stand_in_no_copies.csv" ;;
    rgb_refine) echo "$results/rgb_refine.csv" ;;
    quickstart) echo "docs/images/quickstart.png" ;;
    stand_in_bytes) echo "$results/stand_in_bytes.csv docs/images/stand_in_bytes.png" ;;
    standin_targets) echo "$results/standin_targets*.csv" ;;
    compact_rivals) echo "$results/compact_rivals.csv $results/compact_rivals.txt $results/compact_rivals_image.csv $results/compact_rivals_image.txt docs/images/compact_rivals.png" ;;
    render_rgl) echo "$results/render/*_skymap/* $results/render/satin_skymap_target2/* $results/render/polyester_sky_small*/* docs/images/render_*_skymap_stand_in.png docs/images/render_polyester_sky_small_stand_in.png" ;;
    search_before_after) echo "$results/search_before_after.csv $results/search_before_after_chi_square.csv" ;;
    search_unseen) echo "$results/search_unseen.csv" ;;
    search_time) echo "$results/search_time.csv" ;;
    em_builds) echo "$results/em_builds.csv" ;;
    em_speed) echo "$results/em_speed.csv" ;;
    house_speed) echo "$results/house_speed.csv" ;;
    fit_speed) echo "$results/fit_speed.csv" ;;
    mixed_devices) echo "$results/mixed_devices.csv" ;;
    pinned_k) echo "$results/pinned_k.csv" ;;
    parameterization) echo "$results/parameterization.csv" ;;
    map_accuracy) echo "$results/map_accuracy.csv" ;;
    map_choice) echo "$results/map_choice.csv" ;;
    renderer_chi2) echo "$results/renderer_chi2.csv $results/renderer_chi2_theta_phi.csv" ;;
    tails) echo "$results/tails.csv" ;;
    search_compare) echo "$results/search_compare*.csv $results/search_chi_square.csv docs/images/search_l1_vs_k.png" ;;
    fit_sweep) echo "$results/fit_sweep.csv" ;;
    catalog) echo "$results/catalog_summary.csv" ;;
    scale) echo "$results/scale_*.csv" ;;
    converge) echo "$results/converge/*" ;;
    converge_refine) echo "$results/converge_refine/*" ;;
    converge_light) echo "$results/converge_light/*" ;;
    mis_heuristic) echo "$results/mis_heuristic.csv" ;;
    render) echo "$results/render/*_sky/* $results/render/*_skymap/* docs/images/render_silk_sky_*.png" ;;
    render_room) echo "$results/render/*_room/* docs/images/render_silk_room_*.png" ;;
    em) echo "$results/em_k*_$machine.* docs/images/em_throughput.png" ;;
    render_rays) echo "$results/render_rays_$machine.csv" ;;
    failure_map) echo "$results/failure_map.csv" ;;
    theta_border) echo "$results/theta_border.csv" ;;
    em_precision) echo "$results/em_precision.csv" ;;
    amplitude_objective) echo "$results/amplitude_objective.csv" ;;
    fiber_quadrature) echo "$results/fiber_quadrature.csv" ;;
    rgl_albedo) echo "$results/rgl_albedo.csv" ;;
    rgl_negative) echo "$results/rgl_negative.csv" ;;
    sampling_peers) echo "$results/sampling_peers.csv" ;;
    interpolation) echo "$results/interpolation.csv" ;;
    rgl_resolve) echo "$results/rgl_resolve.csv" ;;
    render_material) echo "$results/render_material.csv" ;;
    render_4d) echo "$results/render_4d.csv" ;;
    fiber_generate) echo "$results/fiber_generate.csv" ;;
    cells_scale) echo "$results/cells_scale.csv" ;;
  esac
}
record_all() {  # the study's files written since the marker
  local study=$1 marker=$2 f
  for f in $(outputs "$study"); do
    [ -f "$f" ] && [ "$f" -nt "$marker" ] && record "$f" "$study"
  done
  return 0
}

run_study() {
  local name=$1
  case $name in
    rgb_stand_in)
      $py bench/rgb_stand_in.py
      # the same tables with the components' colour alone (docs/fitting.md, "Colour copies")
      mkdir -p out/bench_rgb_no_copies
      for f in out/bench_rgb/*.h5; do case $f in *_mixture.h5) ;; *) ln -sf "$PWD/$f" out/bench_rgb_no_copies/ ;; esac; done
      $py bench/rgb_stand_in.py --set 'rgb_copies=~' --work out/bench_rgb_no_copies --csv $results/rgb_stand_in_no_copies.csv ;;
    rgb_refine) $py bench/rgb_refine.py ;;
    quickstart)  # as a first run makes it: every stage, the reference included, from scratch
      rm -rf out/quickstart
      $bin run configs/quickstart.yaml
      cp out/quickstart/render/quickstart.png docs/images/quickstart.png ;;
    stand_in_bytes) rm -rf out/stand_in_bytes && $py bench/stand_in_bytes.py ;;
    standin_targets)  # out/standin_targets/ keeps the fits: a rerun compares and chooses again
      $py bench/standin_targets.py --rows 30
      $py bench/standin_targets.py --rows 45 --only satin_rosaline,paper_white,cotton,cg_sunflower \
        --csv $results/standin_targets_45.csv
      $py bench/standin_targets.py --rows 90 --only paper_white --csv $results/standin_targets_90.csv ;;
    compact_rivals)  # the per-slice study writes the 8 KiB representations the image study renders
      rm -rf out/compact_rivals
      $py bench/compact_rivals.py | tee $results/compact_rivals.txt
      $py bench/compact_image.py | tee $results/compact_rivals_image.txt ;;
    render_rgl)
      for m in satin paper sunflower iris; do
        rm -f out/render_$m/${m}_mixture.h5
        $bin render configs/render/${m}_skymap.yaml
        mkdir -p $results/render/${m}_skymap
        cp out/render_$m/skymap/render.csv out/render_$m/skymap/render.json $results/render/${m}_skymap/
        $bin compare -q out/render_$m/${m}_mixture.h5 out/render_$m/${m}_table.h5 --csv $results/render/${m}_skymap/compare.csv
        cp out/render_$m/skymap/figures/stand_in.png docs/images/render_${m}_skymap_stand_in.png
      done
      for m in satin iris; do  # the cost of a vertex per estimator, interleaved, one thread
        $bin render --no-figures configs/render/${m}_skymap_vertex_cost.yaml
        cp out/render_$m/skymap_vertex_cost/render.csv $results/render/${m}_skymap/vertex_cost.csv
      done
      rm -f out/render_polyester/polyester_small_mixture.h5
      $bin render configs/render/polyester_sky_small.yaml
      cp out/render_polyester/sky_small/render.csv out/render_polyester/sky_small/render.json $results/render/polyester_sky_small/
      cp out/render_polyester/sky_small/figures/stand_in.png docs/images/render_polyester_sky_small_stand_in.png
      # The same two fitted closer (error_target 0.02): the image means against the fits'.
      rm -f out/render_satin/satin_target2_mixture.h5 out/render_polyester/polyester_small_target2_mixture.h5
      $bin render configs/render/satin_skymap_target2.yaml
      mkdir -p $results/render/satin_skymap_target2 $results/render/polyester_sky_small_target2
      cp out/render_satin/skymap_target2/render.csv out/render_satin/skymap_target2/render.json $results/render/satin_skymap_target2/
      $bin render configs/render/polyester_sky_small_target2.yaml
      cp out/render_polyester/sky_small_target2/render.csv out/render_polyester/sky_small_target2/render.json $results/render/polyester_sky_small_target2/ ;;
    search_before_after)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: search_before_after skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      [ -f out/hard.h5 ] || $py bench/hard_table.py out/hard.h5
      [ -f out/bench_rgb/wool.h5 ] || { echo "reproduce: search_before_after needs the tables of rgb_stand_in (run it first)" >&2; return 1; }
      [ -f out/bench_rgb/iris.h5 ] || $bin import rgl -q data/rgl/cc_iris_purple_gem_rgb.bsdf --theta-o 90 --theta-i 90 --phi-i 180 -o out/bench_rgb/iris.h5
      local t="hard=out/hard.h5"
      for m in satin paper sunflower iris silk cotton polyester wool; do t="$t,$m=out/bench_rgb/$m.h5"; done
      $py bench/search_before_after.py --before "$BEFORE" --tables "$t" --walk-only
      rm -f $results/search_before_after_chi_square.csv
      for m in hard satin paper sunflower iris silk cotton polyester wool; do
        local tb=out/bench_rgb/$m.h5
        [ $m = hard ] && tb=out/hard.h5
        for after in after after_walk; do
          $py bench/mixture_chi_square.py $tb out/search_before_after/${m}_before_mixture.h5 \
            out/search_before_after/${m}_${after}_mixture.h5 --label $m${after#after} --csv $results/search_before_after_chi_square.csv
        done
      done ;;
    search_time)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: search_time skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      mkdir -p out/search_time
      [ -f out/search_time/polyester.h5 ] ||
        $bin generate fiber -q --preset polyester --theta-o 180 --theta-i 90 --phi-i 180 -o out/search_time/polyester.h5
      $py bench/search_before_after.py --before "$BEFORE" --tables polyester_thesis=out/search_time/polyester.h5 \
        --runs 3 --walk-only --work out/search_time --csv $results/search_time.csv ;;
    em_builds)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: em_builds skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      $py bench/em_builds.py --before "$BEFORE" --k 8,16,50 --runs 5 --csv $results/em_builds.csv ;;
    em_speed)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: em_speed skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      $py bench/em_speed.py --old "$BEFORE" --new build/bsdfmix --k 8,16,50 --rounds 5 --csv $results/em_speed.csv ;;
    house_speed)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: house_speed skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      $py bench/house_speed.py --old "$BEFORE" --new build/bsdfmix --rounds 5 --csv $results/house_speed.csv ;;
    fit_speed)
      if [ -z "${BEFORE:-}" ]; then echo "reproduce: fit_speed skipped (set BEFORE to the other build's bsdfmix)"; return 0; fi
      $py bench/fit_speed.py --old "$BEFORE" --new build/bsdfmix --rounds ${FIT_SPEED_ROUNDS:-3} --csv $results/fit_speed.csv ;;
    mixed_devices) $py bench/mixed_devices.py --runs 3 --csv $results/mixed_devices.csv ;;
    pinned_k)
      [ -f out/bench_rgb/satin.h5 ] || { echo "reproduce: pinned_k needs the tables of rgb_stand_in (run it first)" >&2; return 1; }
      $py bench/pinned_k.py --table out/bench_rgb/satin.h5 --name satin --min-theta-o 1.2 --k 8,16,32 \
        --csv $results/pinned_k.csv ;;
    search_unseen)
      if [ -z "${BEFORE:-}" ] || [ -z "${RGL_DIR:-}" ]; then
        echo "reproduce: search_unseen skipped (set BEFORE to the other build's bsdfmix and RGL_DIR to a folder of RGL .bsdf files)"; return 0
      fi
      local t="" f stem
      mkdir -p out/unseen
      for f in "$RGL_DIR"/*_rgb.bsdf; do
        stem=$(basename "$f" .bsdf)
        [ -f "data/rgl/$stem.bsdf" ] && continue  # shipped: search_before_after has it
        [ -f "out/unseen/$stem.h5" ] || $bin import rgl -q "$f" --theta-o 90 --theta-i 90 --phi-i 180 -o "out/unseen/$stem.h5"
        t="$t${t:+,}${stem%_rgb}=out/unseen/$stem.h5"
      done
      [ -n "$t" ] || { echo "reproduce: search_unseen: no unshipped *_rgb.bsdf in $RGL_DIR" >&2; return 1; }
      $py bench/search_before_after.py --before "$BEFORE" --tables "$t" --work out/unseen/fits --csv $results/search_unseen.csv ;;
    tails)
      mkdir -p out/parameterization
      [ -f out/parameterization/satin.h5 ] || $bin import rgl -q data/rgl/satin_rosaline_rgb.bsdf -o out/parameterization/satin.h5
      $py bench/parameterization.py --table out/parameterization/satin.h5 --name satin_rosaline --rows 70,75,80,85,89 \
        --maps native,native_t --nu 3 --csv out/parameterization/tails.csv > /dev/null
      $py bench/parameterization.py --table out/parameterization/satin.h5 --name satin_rosaline --rows 70,75,80,85,89 \
        --maps native_t --nu 10 --csv out/parameterization/tails.csv --append > /dev/null
      cp out/parameterization/tails.csv $results/tails.csv ;;
    map_choice) $py bench/map_choice.py --bsdfmix $bin --work out/map_choice --csv $results/map_choice.csv ;;
    map_accuracy) $py bench/map_accuracy.py --bsdfmix $bin --work out/map_accuracy --csv $results/map_accuracy.csv ;;
    renderer_chi2)
      $py bench/renderer_chi2.py --bsdfmix $bin --work out/renderer_chi2 --csv $results/renderer_chi2.csv
      $py bench/renderer_chi2.py --bsdfmix $bin --work out/renderer_chi2 --map theta_phi \
        --csv $results/renderer_chi2_theta_phi.csv ;;
    parameterization)
      mkdir -p out/parameterization
      local rows=0,5,10,45,70,75,80,85,89
      [ -f out/parameterization/satin.h5 ] || $bin import rgl -q data/rgl/satin_rosaline_rgb.bsdf -o out/parameterization/satin.h5
      [ -f out/parameterization/iris.h5 ] || $bin import rgl -q data/rgl/cc_iris_purple_gem_rgb.bsdf -o out/parameterization/iris.h5
      # the two tables at once, one per core; then the project's fits of the same rows
      $py bench/parameterization.py --table out/parameterization/satin.h5 --name satin_rosaline --rows $rows \
        --csv out/parameterization/satin.csv > out/parameterization/satin.log &
      $py bench/parameterization.py --table out/parameterization/iris.h5 --name cc_iris_purple_gem --rows $rows \
        --csv out/parameterization/iris.csv > out/parameterization/iris.log
      wait
      $py bench/parameterization.py --table out/parameterization/satin.h5 --name satin_rosaline --rows $rows --k 4,8,16 \
        --restarts 0 --bsdfmix $bin --csv out/parameterization/satin.csv --append > /dev/null
      $py bench/parameterization.py --table out/parameterization/iris.h5 --name cc_iris_purple_gem --rows $rows --k 4,8,16 \
        --restarts 0 --bsdfmix $bin --csv out/parameterization/iris.csv --append > /dev/null
      cat out/parameterization/satin.csv > $results/parameterization.csv
      tail -n +2 out/parameterization/iris.csv >> $results/parameterization.csv ;;
    search_compare)
      $py bench/search_compare.py --runs 1 --chart
      $py bench/search_compare.py --tables polyester --csv $results/search_compare_polyester_best3.csv
      # walk alone against walk + L1 refinement on the RGL rows (docs/fitting.md, "The L1 refinement")
      rm -f $results/search_chi_square.csv
      for t in satin paper sunflower; do
        $py bench/mixture_chi_square.py out/bench_search/$t.h5 out/bench_search/${t}_smem_none_search_mixture.h5 \
          out/bench_search/${t}_smem_l1_search_mixture.h5 --label $t --csv $results/search_chi_square.csv
      done ;;
    fit_sweep) RUNS=3 bench/fit_sweep.sh ;;
    catalog) $bin catalog configs/catalog.yaml && cp out/catalog/summary.csv $results/catalog_summary.csv ;;
    scale) RUNS=3 bench/scale.sh ;;
    converge)
      for m in polyester cotton satin; do
        $bin run configs/converge_$m.yaml
        cp out/converge_$m/${m}_convergence.csv out/converge_$m/${m}_convergence_tail.csv $results/converge/
      done ;;
    converge_light)
      for m in polyester cotton satin paper; do
        $bin run configs/converge_light_$m.yaml
        cp out/converge_light_$m/${m}_convergence*.csv $results/converge_light/
      done ;;
    converge_refine)
      # The tail is scene- and estimator-independent: one short study per variant gives it.
      local w=out/converge_refine
      mkdir -p $w $results/converge_refine
      for r in l1 none; do
        sed -e "/^table:/!s|out/converge_satin/|$w/${r}_|" -e "0,/^  seed: 1$/s//  seed: 1\n  refine: $r/" \
            -e "s|^  samples_max: .*|  samples_max: 64|" -e "s|^  runs: .*|  runs: 2|" \
            -e "s|^  estimators: .*|  estimators: [us_tab]|" -e "/^charts:/,\$d" configs/converge_satin.yaml > $w/$r.yaml
        $bin run -q $w/$r.yaml
        cp $w/${r}_satin_convergence_tail.csv $results/converge_refine/satin_refine_${r}_tail.csv
      done ;;
    mis_heuristic) bench/mis_heuristic.sh ;;
    render)  # RENDER_FIBERS (default: all four) renders some of them again
      for f in ${RENDER_FIBERS:-silk cotton wool polyester}; do
        for s in sky skymap; do
          $bin render configs/render/${f}_${s}.yaml
          mkdir -p $results/render/${f}_${s}
          cp out/render_$f/$s/render.csv out/render_$f/$s/render.json $results/render/${f}_${s}/
        done
      done
      case " ${RENDER_FIBERS:-silk} " in *" silk "*)
        cp out/render_silk/sky/figures/figure_sheet.png docs/images/render_silk_sky_sheet.png
        cp out/render_silk/sky/figures/error_vs_time.png docs/images/render_silk_sky_error_time.png
        cp out/render_silk/sky/figures/stand_in.png docs/images/render_silk_sky_stand_in.png ;;
      esac ;;
    render_room)
      for f in silk cotton wool polyester; do
        $bin render configs/render/${f}_room.yaml
        mkdir -p $results/render/${f}_room
        cp out/render_$f/room/render.csv out/render_$f/room/render.json $results/render/${f}_room/
      done
      cp out/render_silk/room/figures/figure_sheet.png docs/images/render_silk_room_sheet.png
      cp out/render_silk/room/figures/error_vs_time.png docs/images/render_silk_room_error_time.png ;;
    em)
      local b=build-bench/bsdfmix
      [ -x $b ] || b=$bin  # scripts/setup's build has the peers (BSDFMIX_BUILD_BENCH is on by default)
      for k in 8 16 50; do $b bench em --k $k --repeat 5 --csv $results/em_k${k}_$machine.csv > $results/em_k${k}_$machine.txt 2>&1; done
      mkdir -p out
      $py scripts/plot_bench.py $results/em_k16_$machine.csv $results/em_k50_$machine.csv -o out/em_throughput
      cp out/em_throughput.png docs/images/em_throughput.png ;;
    em_precision) BSDFMIX_MEASURE_CSV=$results/em_precision.csv build/tests/em_test "[.measure]" ;;
    theta_border) BSDFMIX_MEASURE_CSV=$results/theta_border.csv build/tests/search_test "[.measure]" ;;
    fiber_quadrature) BSDFMIX_MEASURE_CSV=$results/fiber_quadrature.csv build/tests/fiber_test "[.measure]" ;;
    fiber_generate) $py bench/fiber_generate.py ;;
    cells_scale) $py bench/cells_scale.py ${BEFORE:+--before "$BEFORE"} ;;
    rgl_negative) $py bench/rgl_negative.py --csv $results/rgl_negative.csv ;;
    rgl_albedo) BSDFMIX_MEASURE_CSV=$results/rgl_albedo.csv build/tests/rgl_test "[.measure]" ;;
    sampling_peers)
      # each shipped RGL material and each fiber preset (f the table) at the default grid and
      # fit settings (as rgb_stand_in); 20 random view elevations, constant light and the sky,
      # 2^16 samples per sampler (SAMPLING_PEERS_SAMPLES sets fewer; docs/sampling.md,
      # "Against the file's own sampler")
      local w=out/sampling_peers f m sky=configs/scenes/sky.yaml
      local args="--directions 20 --samples ${SAMPLING_PEERS_SAMPLES:-65536} --seed 1 --scene $sky --light-cache $w/light_mixtures"
      mkdir -p $w
      for f in data/rgl/*_rgb.bsdf; do
        m=$(basename "$f" _rgb.bsdf)
        [ -f $w/$m.h5 ] || $bin import rgl -q "$f" -o $w/$m.h5
        if [ ! -f $w/${m}_mixture.h5 ]; then
          printf 'table: %s\nfit:\n  output: %s\n  report: %s\n  search_report: %s\n' \
            $w/$m.h5 $w/${m}_mixture.h5 $w/${m}_fit.csv $w/${m}_search.csv > $w/$m.yaml
          $bin fit -q $w/$m.yaml > /dev/null
        fi
        $bin bench sampling --rgl "$f" --table $w/$m.h5 --mixture $w/${m}_mixture.h5 $args --csv $w/$m.csv
      done
      for m in silk cotton polyester wool; do
        [ -f $w/$m.h5 ] || $bin generate fiber -q --preset $m -o $w/$m.h5
        if [ ! -f $w/${m}_mixture.h5 ]; then
          printf 'table: %s\nfit:\n  output: %s\n  report: %s\n  search_report: %s\n' \
            $w/$m.h5 $w/${m}_mixture.h5 $w/${m}_fit.csv $w/${m}_search.csv > $w/$m.yaml
          $bin fit -q $w/$m.yaml > /dev/null
        fi
        $bin bench sampling --table $w/$m.h5 --mixture $w/${m}_mixture.h5 $args --csv $w/$m.csv
      done
      { head -n 1 $w/silk.csv
        for f in data/rgl/*_rgb.bsdf; do tail -n +2 $w/$(basename "$f" _rgb.bsdf).csv; done
        for m in silk cotton polyester wool; do tail -n +2 $w/$m.csv; done; } > $results/sampling_peers.csv ;;
    interpolation)
      ls out/sampling_peers/*_mixture.h5 > /dev/null 2>&1 || run_study sampling_peers
      $py bench/interpolation.py --csv $results/interpolation.csv ;;
    rgl_resolve) $py bench/rgl_resolve.py --csv $results/rgl_resolve.csv ;;
    render_material) $py bench/render_material.py --csv $results/render_material.csv ;;
    render_4d) $py bench/render_4d.py --csv $results/render_4d.csv ;;
    failure_map) $py scripts/failure_map.py && cp out/failure_map/failure_map.csv $results/failure_map.csv ;;
    render_rays)
      local r=build/bench/bsdfmix_bench_render_rays
      [ -x $r ] || r=build-bench/bench/bsdfmix_bench_render_rays
      [ -x $r ] || { echo "reproduce: render_rays needs a build with BSDFMIX_BUILD_BENCH=ON" >&2; return 1; }
      $r --csv $results/render_rays_$machine.csv ;;
    amplitude_objective)
      [ -f out/bench_rgb/satin_mixture.h5 ] || $py bench/rgb_stand_in.py
      $py bench/amplitude_objective.py ;;
    *) echo "reproduce: unknown study '$name' (bench/reproduce.sh --list)" >&2; exit 2 ;;
  esac
}

quick=0
chosen=()
for a in "$@"; do
  case $a in
    -h|--help) usage; exit 0 ;;
    --list) usage | sed -n '/^Studies:/,$p'; exit 0 ;;
    --quick) quick=1 ;;
    -*) echo "reproduce: unknown option '$a' (bench/reproduce.sh --help)" >&2; exit 2 ;;
    *) chosen+=("$a") ;;
  esac
done
if [ ${#chosen[@]} -eq 0 ]; then
  for s in "${studies[@]}"; do
    IFS=: read -r name minutes q what <<<"$s"
    if [ $quick = 0 ] || [ "$q" = quick ]; then chosen+=("$name"); fi
  done
fi
for name in "${chosen[@]}"; do
  known=0
  for s in "${studies[@]}"; do [ "${s%%:*}" = "$name" ] && known=1; done
  [ $known = 1 ] || { echo "reproduce: unknown study '$name' (bench/reproduce.sh --list)" >&2; exit 2; }
done

[ -x $bin ] || { echo "reproduce: $bin missing: run scripts/setup first" >&2; exit 1; }
marker=$(mktemp)
trap 'rm -f "$marker"' EXIT
for name in "${chosen[@]}"; do
  start=$(date +%s)
  echo "reproduce: $name (commit $commit)"
  touch "$marker"
  run_study "$name"
  record_all "$name" "$marker"
  echo "reproduce: $name done in $(( $(date +%s) - start )) s"
done
