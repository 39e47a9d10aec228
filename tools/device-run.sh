#!/bin/bash
# One device session (packed by tools/pack-device-run): devices, the kernel tests on the GPU,
# benchmarks, renders. Results under $OUT (at most 8 files come back).
echo libnvidia-opencl.so.1 > /etc/OpenCL/vendors/nvidia.icd
cd "$(dirname "$0")"
ldconfig -p | grep -q libOpenCL.so.1 || export LD_LIBRARY_PATH=$PWD/lib
{
  nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv; head -2 /etc/os-release; nproc
  ./clpt devices
  export CLPT_DEVICE=NVIDIA
  for t in layout rng geometry render; do
    ./test_$t --test-threads=4 > /tmp/test_$t.txt 2>&1; echo "tests/$t.rs on the H200: $(grep 'test result' /tmp/test_$t.txt)"
    grep -q "FAILED" /tmp/test_$t.txt && grep -v "^ *[0-9]*: \|^ *at " /tmp/test_$t.txt | head -40
  done
} > $OUT/info.txt 2>&1; cat $OUT/info.txt
export CLPT_DEVICE=NVIDIA
{
  echo "## H200, cold build (CUDA_CACHE_DISABLE=1), 1024 spp"; CUDA_CACHE_DISABLE=1 ./clpt bench smallpt.txt case2.txt case5.txt --spp 1024
  echo "## H200, warm, 4096 spp"; ./clpt bench smallpt.txt case2.txt case5.txt --spp 4096
  echo "## PoCL 5.0 on the H200 machine's 16 CPU cores, cold (POCL_KERNEL_CACHE=0), 32 spp"
  POCL_KERNEL_CACHE=0 CLPT_DEVICE=Portable ./clpt bench smallpt.txt case2.txt case5.txt --spp 32
} 2>&1 | grep -v warning > $OUT/bench.txt; cat $OUT/bench.txt
./clpt render smallpt.txt --spp 16384 -o $OUT/smallpt_16384.png -v -q 2>&1 | tee $OUT/render.txt
./clpt render case5.txt --spp 4096 -o $OUT/case5_4096.png -q 2>&1 | tee -a $OUT/render.txt
./clpt render smallpt.txt --spp 1024 --seed 1 -o /tmp/det_a.pfm -q 2>/dev/null; ./clpt render smallpt.txt --spp 1024 --seed 1 -o /tmp/det_b.pfm -q 2>/dev/null
cmp /tmp/det_a.pfm /tmp/det_b.pfm && echo "determinism: two renders with seed 1 identical" | tee -a $OUT/render.txt
