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
  echo "## H200, cold build (CUDA_CACHE_DISABLE=1), 1024 spp"
  CUDA_CACHE_DISABLE=1 ./clpt bench scenes/smallpt.txt $seed/case2_softshadows_colorbleeding.txt $seed/case5_light_balls.txt $seed/case0_texture.txt scenes/textures.txt --spp 1024
  echo "## H200, warm, 4096 spp"
  ./clpt bench scenes/smallpt.txt $seed/case2_softshadows_colorbleeding.txt $seed/case5_light_balls.txt $seed/case0_texture.txt scenes/textures.txt --spp 4096
} 2>&1 | grep -v warning > $OUT/bench.txt; cat $OUT/bench.txt
{
  echo "## case0_texture.txt at the original's 2560x1440, 800 spp (original: 664 s on an RTX 2060 Super)"
  ./clpt render $seed/case0_texture.txt --spp 800 -o $OUT/case0_800spp.png -v -q 2>&1
  ./clpt render $seed/case0_texture.txt --spp 800 --texture-filter nearest -o /tmp/case0_nearest.png -q 2>&1
  echo "## scenes/textures.txt, 1280x720, 4096 spp"
  ./clpt render scenes/textures.txt --spp 4096 -o $OUT/textures_4096spp.png -q 2>&1
  ./clpt render scenes/smallpt.txt --spp 1024 --seed 1 -o /tmp/det_a.pfm -q 2>/dev/null
  ./clpt render scenes/smallpt.txt --spp 1024 --seed 1 -o /tmp/det_b.pfm -q 2>/dev/null
  cmp /tmp/det_a.pfm /tmp/det_b.pfm && echo "determinism: two renders with seed 1 identical"
} > $OUT/render.txt 2>&1; cat $OUT/render.txt
