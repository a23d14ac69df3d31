#!/bin/bash
# Device check 2 for issue 35: the networks on burn's wgpu backend on a real GPU (prebuilt test-profile binaries).
# Run from the repository root on the GPU machine, with .devbin/ holding xz-compressed, stripped test-profile
# binaries built here with `cargo test --workspace --features wgpu --no-run` (tacsim, the sim crate's lib test and
# tests/gpu.rs, the model crate's tests/wgpu.rs) and .gl/ the Vulkan loader packages (libvulkan1 and friends).
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
if ! ls /usr/share/vulkan/icd.d/*nvidia* /etc/vulkan/icd.d/*nvidia* >/dev/null 2>&1; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
mkdir -p /tmp/b && for f in tacsim model_wgpu_test; do xz -dc .devbin/$f.xz > /tmp/b/$f; chmod +x /tmp/b/$f; done
mkdir -p /work && ln -sfn "$PWD" /work/main
export TACSIM_REQUIRE_GPU=1
# Three runs, the tests on parallel threads as in CI: each must give the same figures (the seeded start).
for i in 1 2 3; do
  timeout 60 /tmp/b/model_wgpu_test --nocapture 2>&1 | grep -v XDG | tee -a $OUT/model_wgpu.log | grep -E "one step: loss|losses|outputs|images|test result|differ"
done
/tmp/b/tacsim generate quick --quiet --out /tmp/q | tail -1
for be in flex wgpu; do
  echo "== posenet --backend $be"
  (time timeout 150 /tmp/b/tacsim train posenet --data /tmp/q --out /tmp/r-$be --backend $be --size 128 --epochs 4 --batch 32 --quiet) 2>&1 | grep -v XDG | tail -6
done
