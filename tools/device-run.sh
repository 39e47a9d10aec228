#!/bin/bash
# One device session (packed by tools/pack-device-run), in stages, so that a session can spread
# them over calls of the device tool's 10-minute limit:
#   bash device-run/run.sh [STAGE ...]      (no stage: all of them, in this order)
# info        the GPU, the OpenCL devices, every scene built and rendered once by NVIDIA's compiler
# tests       the kernel tests on the GPU (CLPT_DEVICE=NVIDIA)
# estimators  tools/estimators.sh over the showcases at defaults and fixed settings (about 8 minutes
#             on the H200; the rest below in another call); SETTINGS=auto: the defaults alone
#             (about 1.5 minutes: with `hashes`, a new build's check in one call)
# scenes      tools/estimators.sh over case2 and scenes/ at defaults and all six fixed settings
# films       checkpoints, then devices:
#   checkpoints  the cost of writing a film file, and of checkpoints in a render
#   devices      several devices (the GPU and the CPU device, if there is one)
# trials      the trial's cost: each binary of $TRIAL_BINS (default ./clpt; built by hand with
#             other trial shares, carried in device-run/) at the defaults against each short
#             scene's best fixed setting (or $TRIAL_SCENES: FILE:SPP:LIGHT:RR ...), $REPS rounds
#             (default 3), into $OUT/trials.csv (or $TRIALS_CSV)
# launches    each showcase and the GPU-heavy scenes with light sampling on and off (roulette 0.3)
#             at $LAUNCHES ms launches (default 400 1000 1600; --launch-ms), and meshes' trial
#             (-v) at each, into $OUT/launches.csv (about 4 minutes on the H200)
# mitsuba     tools/mitsuba-compare.py --cuda on the room and the dragon room (needs .whl/ from tools/pack-mitsuba-wheels carried)
# bench       cold builds and rates of each scene's program and of all features; the goblet alone
# hashes      tests/images.rs on the GPU: with a `pre/test_images` beside run.sh (the test built from
#             an older checkout, tests/images.rs copied in), that build's hashes are recorded and
#             this build's compared with them (issue 16's proof: the same bits before and after);
#             without one, this build's hashes are recorded. Both tables come back in $OUT.
# programs    whether a scene's program and the all-features one render the same bits on the GPU
#             (tests/features.rs' question), as built and with fma contraction off
# Results under $OUT, one file a stage (at most 8 files come back).
echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
repo=$PWD
cd "$(dirname "$0")"
ldconfig -p | grep -q libOpenCL.so.1 || export LD_LIBRARY_PATH=$PWD/lib
export CLPT_SEED_DIR=$PWD/seed
# The tests read scenes, assets and kernels/types.h at the checkout they were built in (its path
# compiled in, built_in); that path leads to this copy of the repository where it is absent.
built_in=$(cat built_in 2>/dev/null || true)
if [ -n "$built_in" ] && [ ! -e "$built_in" ]; then
  mkdir -p "$(dirname "$built_in")" && ln -s "$repo" "$built_in"
fi
seed=seed/testcases
showcases="$seed/case0_texture.txt $seed/case1_dof_mesh.txt $seed/case2_softshadows_colorbleeding.txt
  $seed/case3_wineglass.txt $seed/case4_planets.txt $seed/case5_light_balls.txt"
stages=("$@")
[ ${#stages[@]} -eq 0 ] && stages=(info tests estimators scenes films mitsuba bench)

info() {
  nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv; head -2 /etc/os-release; nproc
  ./clpt devices
  for s in $showcases scenes/*.txt; do
    echo "$s: $(CLPT_DEVICE=NVIDIA ./clpt render "$s" --width 64 --height 36 --spp 8 -o /tmp/x.pfm -q 2>&1 | tail -1)"
  done
}

tests() {
  export CLPT_DEVICE=NVIDIA
  # The tests of the newest kernel changes first; none started after TESTS_BUDGET seconds.
  local start=$SECONDS
  for t in test_trial test_strategy test_render test_far test_shadow_rays test_layout test_geometry test_revsurface \
      $(ls test_* | grep -v -x -e test_trial -e test_strategy -e test_far -e test_render -e test_shadow_rays -e test_layout \
        -e test_geometry -e test_revsurface); do
    if [ $((SECONDS - start)) -gt "${TESTS_BUDGET:-400}" ]; then echo "$t: not run (budget)"; continue; fi
    timeout 300 ./$t --test-threads=4 > /tmp/$t.txt 2>&1; rc=$?
    echo "$t on the GPU (exit $rc): $(grep 'test result' /tmp/$t.txt)"
    [ $rc -ne 0 ] && grep -v "^ *[0-9]*: \|^ *at " /tmp/$t.txt | grep -v "^test .* ok$" | tail -30
  done
}

estimators() {
  export CLPT_DEVICE=NVIDIA
  # The showcases at the original's sizes and samples: the defaults, light sampling off with
  # roulette below 1 (the `--no-nee` of the issue), and on and off with roulette below 0.3
  # (0.5 lost by 5 to 13% in every earlier run); light sampling costs 3.5 to 5 times a path
  # there, so this takes about 8 minutes.
  SETTINGS="${SETTINGS:-auto off:1 on:0.3 off:0.3}" tools/estimators.sh ./clpt $OUT/estimators.csv \
    $seed/case0_texture.txt:800 $seed/case3_wineglass.txt:1000 $seed/case1_dof_mesh.txt:800
}

scenes() {
  export CLPT_DEVICE=NVIDIA
  tools/estimators.sh ./clpt $OUT/scenes.csv $seed/case2_softshadows_colorbleeding.txt:512 \
    scenes/ceiling_room.txt:4096 scenes/textures.txt:2048 scenes/goblet.txt:256 \
    scenes/meshes.txt:2048 scenes/room.txt:4096 scenes/small_light.txt:4096 \
    scenes/smallpt.txt:4096 scenes/lights.txt:1024
}

wall() { local t=$EPOCHREALTIME; "$@" > /tmp/wall.log 2>&1; local rc=$?
  echo "$(python3 -c "print(f'{$EPOCHREALTIME - $t:.3f}')") s wall (exit $rc): $(tail -1 /tmp/wall.log)"; }

films() { checkpoints; devices; }

checkpoints() {
  export CLPT_DEVICE=NVIDIA
  echo "## checkpoint cost: the built-in room at 1 spp without and with --film (3 runs each)"
  for size in "1280 720" "1920 1080" "3840 2160"; do
    set -- $size
    for run in 1 2 3; do
      wall ./clpt render --width $1 --height $2 --spp 1 -q --light-sampling off --rr-threshold 0.3 -o /tmp/c.png
      wall ./clpt render --width $1 --height $2 --spp 1 -q --light-sampling off --rr-threshold 0.3 -o /tmp/c.png --film /tmp/f.exr
    done
    ls -l /tmp/f.exr
  done
  echo "## a render with checkpoints every 2 s and without (1920x1080, 4096 spp)"
  for run in 1 2; do
    wall ./clpt render scenes/smallpt.txt --width 1920 --height 1080 --spp 4096 -q --checkpoint /tmp/ck.exr \
      --checkpoint-every 2 --light-sampling on --rr-threshold 0.3 -o /tmp/ck.png
    wall ./clpt render scenes/smallpt.txt --width 1920 --height 1080 --spp 4096 -q \
      --light-sampling on --rr-threshold 0.3 -o /tmp/nock.png
  done
}

devices() {
  export CLPT_DEVICE=NVIDIA
  echo "## several devices: the GPU alone, the CPU alone (fewer samples: its rate), both (CPU listed first)"
  ./clpt devices
  gpu=$(./clpt devices | grep -m1 '(GPU' | grep -o '^\[[0-9]*' | tr -d '[')
  cpu=$(./clpt devices | grep -m1 '(CPU' | grep -o '^\[[0-9]*' | tr -d '[')
  for s in "scenes/smallpt.txt 16384 64" "$seed/case0_texture.txt 2048 8"; do
    set -- $s
    echo "# $1, --device $gpu (GPU), $2 spp"
    wall ./clpt render $1 --spp $2 --device $gpu -q --light-sampling off --rr-threshold 0.3 -o /tmp/m0.pfm
    echo "# $1, --device $cpu (CPU), $3 spp"
    wall timeout 120 ./clpt render $1 --spp $3 --device $cpu -q --light-sampling off --rr-threshold 0.3 -o /tmp/m1.pfm
    echo "# $1, --device $cpu,$gpu, $2 spp"
    wall timeout 200 ./clpt render $1 --spp $2 --device $cpu,$gpu -q --light-sampling off --rr-threshold 0.3 -o /tmp/m01.pfm
    tail -4 /tmp/wall.log
    ./clpt compare /tmp/m0.pfm /tmp/m01.pfm 2>&1 | tail -1
  done
  # The strategy pinned: `auto`'s choice follows measured times.
  for run in a b; do
    ./clpt render scenes/smallpt.txt --spp 1024 --seed 1 --device $cpu,$gpu --light-sampling on \
      --rr-threshold 0.3 -o /tmp/det_$run.pfm -q 2>/dev/null
  done
  cmp /tmp/det_a.pfm /tmp/det_b.pfm && echo "determinism: two two-device renders with seed 1 identical"
}

trials() {
  export CLPT_DEVICE=NVIDIA
  local best=${TRIAL_SCENES:-"$seed/case2_softshadows_colorbleeding.txt:512:off:0.3 scenes/ceiling_room.txt:4096:on:0.3
    scenes/room.txt:4096:on:1 scenes/small_light.txt:4096:on:0.3 scenes/smallpt.txt:4096:on:0.3
    scenes/goblet.txt:256:off:0.3"}
  local csv=${TRIALS_CSV:-$OUT/trials.csv}
  echo "scene,setting,spp,seconds,relmse_estimate,relmse_x_seconds,estimator,binary,round" > $csv
  for round in $(seq "${REPS:-3}"); do
    for entry in $best; do
      IFS=: read -r file spp light rr <<< "$entry"
      for bin in ${TRIAL_BINS:-./clpt} fixed; do
        if [ $bin = fixed ]; then
          SETTINGS=$light:$rr tools/estimators.sh ./clpt /tmp/t.csv $file:$spp > /dev/null
        else
          SETTINGS=auto tools/estimators.sh $bin /tmp/t.csv $file:$spp > /dev/null
        fi
        tail -1 /tmp/t.csv | sed "s|\$|,$(basename $bin),$round|" | tee -a $csv
      done
    done
  done
}

launches() {
  export CLPT_DEVICE=NVIDIA
  local csv=$OUT/launches.csv
  echo "launch_ms,scene,setting,spp,seconds,relmse_estimate,relmse_x_seconds,estimator" > $csv
  for ms in ${LAUNCHES:-400 1000 1600}; do
    for entry in $seed/case1_dof_mesh.txt:160:off $seed/case1_dof_mesh.txt:48:on \
        $seed/case0_texture.txt:200:off $seed/case0_texture.txt:64:on $seed/case3_wineglass.txt:250:off \
        scenes/meshes.txt:1024:off scenes/meshes.txt:512:on scenes/textures.txt:2048:off \
        scenes/textures.txt:512:on scenes/goblet.txt:128:on; do
      IFS=: read -r file spp light <<< "$entry"
      SETTINGS=$light:0.3 EXTRA="--launch-ms $ms" tools/estimators.sh ./clpt /tmp/l.csv $file:$spp > /dev/null
      tail -1 /tmp/l.csv | sed "s|^|$ms,|" | tee -a $csv
    done
    echo "# meshes at defaults, --launch-ms $ms"
    ./clpt render scenes/meshes.txt --spp 2048 --seed 1 -v --launch-ms $ms -o /tmp/l.pfm 2>&1 |
      grep -E "estimator:|trial:|spp in|passes"
  done
}

mitsuba() {
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site "$repo"/.whl/*.whl || return
  export PYTHONPATH=/tmp/site PYTHONUNBUFFERED=1 CLPT_DEVICE=NVIDIA
  for scene in room dragon_room; do
    python3 "$repo"/tools/mitsuba-compare.py --cuda --clpt ./clpt --scene $scene --width 1280 --height 960 \
      --seconds 2 --reference-factor 8 --mitsuba-samplers independent,ldsampler,multijitter,orthogonal \
      --out /tmp/cmp-$scene
  done
}

programs() {
  export CLPT_DEVICE=NVIDIA
  # The kernels again, with `#pragma OPENCL FP_CONTRACT OFF` first (triangle.h's own switch back
  # to on turned off too): where only contraction tells the programs apart, these agree.
  rm -rf /tmp/kc && cp -r kernels /tmp/kc
  sed -i '1i #pragma OPENCL FP_CONTRACT OFF' /tmp/kc/pathtracer.cl
  sed -i 's/FP_CONTRACT ON/FP_CONTRACT OFF/' /tmp/kc/triangle.h
  for s in textures meshes; do for light in on off; do for k in as-built contraction-off; do
    local extra=()
    [ $k = contraction-off ] && extra=(--kernels /tmp/kc)
    for f in specialised all; do
      local all=()
      [ $f = all ] && all=(--all-features)
      ./clpt render scenes/$s.txt --width 40 --height 24 --spp 4 --seed 11 --light-sampling $light \
        --rr-threshold 0.3 --lanes 1 "${all[@]}" "${extra[@]}" -q -o /tmp/p-$f.pfm 2>&1 |
        grep -v " spp in \|^estimator: "
    done
    if cmp -s /tmp/p-specialised.pfm /tmp/p-all.pfm; then
      echo "$s, light sampling $light, $k: the same bits"
    else
      echo "$s, light sampling $light, $k: differ: $(./clpt compare /tmp/p-specialised.pfm /tmp/p-all.pfm 2>&1 | tr '\n' ' ')"
    fi
  done; done; done
}

hashes() {
  export CLPT_DEVICE=NVIDIA
  local pre="$repo/device-run/pre/test_images"
  [ -x "$pre" ] || pre="$PWD/pre/test_images"
  if [ -x "$pre" ]; then
    CLPT_RECORD_HASHES=1 CLPT_IMAGE_HASHES=$OUT/pre-hashes.txt timeout 300 "$pre" --nocapture 2>&1 | tail -3
    echo "== this build against the older one's hashes"
    CLPT_IMAGE_HASHES=$OUT/pre-hashes.txt timeout 300 ./test_images --nocapture 2>&1 | tail -50
  else
    CLPT_RECORD_HASHES=1 CLPT_IMAGE_HASHES=$OUT/hashes.txt timeout 300 ./test_images --nocapture 2>&1 | tail -3
  fi
}

bench() {
  export CLPT_DEVICE=NVIDIA
  echo "## H200, cold build (CUDA_CACHE_DISABLE=1), 256 spp: each scene's own program, then all features"
  for features in "" --all-features; do
    CUDA_CACHE_DISABLE=1 timeout 100 ./clpt bench scenes/smallpt.txt $showcases scenes/goblet.txt tools/dragon_rays.txt \
      --spp 256 $features 2>&1 | grep -v warning
  done
  echo "## cargo bench --bench revsurface (goblet alone)"
  ./bench_revsurface
}

for stage in "${stages[@]}"; do
  start=$SECONDS
  "$stage" > $OUT/$stage.txt 2>&1
  echo "## $stage took $((SECONDS - start)) s" >> $OUT/$stage.txt
  cat $OUT/$stage.txt
done
