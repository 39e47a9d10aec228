#!/bin/bash
# One device session (packed by tools/pack-device-run): devices, the kernel tests on the GPU,
# benchmarks, renders. Results under $OUT (at most 8 files come back).
echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
cd "$(dirname "$0")"
ldconfig -p | grep -q libOpenCL.so.1 || export LD_LIBRARY_PATH=$PWD/lib
export CLPT_SEED_DIR=$PWD/seed
seed=seed/testcases
{
  nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv; head -2 /etc/os-release; nproc
  ./clpt devices
  export CLPT_DEVICE=NVIDIA
  for t in test_*; do
    ./$t --test-threads=4 > /tmp/$t.txt 2>&1; echo "$t on the H200: $(grep 'test result' /tmp/$t.txt)"
    grep -q "FAILED" /tmp/$t.txt && grep -v "^ *[0-9]*: \|^ *at " /tmp/$t.txt | head -40
  done
} > $OUT/info.txt 2>&1; cat $OUT/info.txt
export CLPT_DEVICE=NVIDIA
{
  echo "## cargo bench --bench revsurface (goblet alone), degree 3 compiled in"
  ./bench_revsurface
  echo "## the same, degree read at run time"
  CLPT_BENCH_REV_DEGREE=0 ./bench_revsurface
} > $OUT/bench_revsurface.txt 2>&1; cat $OUT/bench_revsurface.txt
{
  echo "## H200, cold build (CUDA_CACHE_DISABLE=1), 256 spp: each scene's own program, then all features"
  for features in "" --all-features; do
    CUDA_CACHE_DISABLE=1 ./clpt bench scenes/smallpt.txt $seed/case0_texture.txt $seed/case1_dof_mesh.txt $seed/case2_softshadows_colorbleeding.txt $seed/case3_wineglass.txt $seed/case4_planets.txt $seed/case5_light_balls.txt scenes/goblet.txt tools/dragon_rays.txt --spp 256 $features
  done
} 2>&1 | grep -v warning > $OUT/bench.txt; cat $OUT/bench.txt
{
  echo "## case3_wineglass.txt at the original's 1920x1080, 1000 spp (original: 9653 s on an RTX 2060 Super)"
  ./clpt render $seed/case3_wineglass.txt --spp 1000 -o $OUT/case3_1000spp.png -v -q 2>&1
  echo "## scenes/goblet.txt, 1920x1080, 1000 spp"
  ./clpt render scenes/goblet.txt --spp 1000 -o $OUT/goblet_1000spp.png -q 2>&1
  echo "## case1 and case0 at their original sizes and samples"
  ./clpt render $seed/case1_dof_mesh.txt --spp 800 -o /tmp/case1.png -q 2>&1
  ./clpt render $seed/case0_texture.txt --spp 800 -o /tmp/case0.png -q 2>&1
  ./clpt render scenes/smallpt.txt --spp 1024 --seed 1 -o /tmp/det_a.pfm -q 2>/dev/null
  ./clpt render scenes/smallpt.txt --spp 1024 --seed 1 -o /tmp/det_b.pfm -q 2>/dev/null
  cmp /tmp/det_a.pfm /tmp/det_b.pfm && echo "determinism: two renders with seed 1 identical"
} > $OUT/render.txt 2>&1; cat $OUT/render.txt
