#!/bin/bash
# Device check for issue 35: the GPU path's parity and bench on a real GPU (prebuilt test-profile binaries, stripped).
# Run from the repository root on the GPU machine, with .devbin/ holding xz-compressed, stripped test-profile
# binaries built here with `cargo test --workspace --features wgpu --no-run` (tacsim, the sim crate's lib test and
# tests/gpu.rs, the model crate's tests/wgpu.rs) and .gl/ the Vulkan loader packages (libvulkan1 and friends).
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
echo "libvulkan: $(ldconfig -p | grep -c libvulkan)"; ls /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/nvidia/share/vulkan/icd.d 2>&1
if ! ls /usr/share/vulkan/icd.d/*nvidia* /etc/vulkan/icd.d/*nvidia* >/dev/null 2>&1; then
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
fi
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader; nproc
mkdir -p /tmp/b && for f in tacsim gpu_test sim_test; do xz -dc .devbin/$f.xz > /tmp/b/$f; chmod +x /tmp/b/$f; done
mkdir -p /work && ln -sfn "$PWD" /work/main
export TACSIM_REQUIRE_GPU=1
timeout 150 /tmp/b/gpu_test --nocapture 2>&1 | grep -v XDG | tee $OUT/gpu_test.log | grep -E "adapter|differ|apart|test result"
timeout 150 /tmp/b/sim_test gpu --nocapture 2>&1 | grep -v XDG | tee $OUT/sim_test.log | grep -E "differ|apart|test result|panicked"
timeout 240 /tmp/b/tacsim bench --device gpu --samples 16 --plot $OUT/bench.svg > $OUT/bench.txt 2> $OUT/bench.err; grep -E "GPU|taps|a tap" $OUT/bench.txt; tail -2 $OUT/bench.err
/tmp/b/tacsim generate quick --quiet --out /tmp/q/cpu | tee $OUT/gen.txt
/tmp/b/tacsim generate quick --quiet --out /tmp/q/gpu --device gpu 2>&1 | grep -v XDG | tee -a $OUT/gen.txt
for f in /tmp/q/cpu/images/*.png; do cmp -s $f /tmp/q/gpu/images/$(basename $f) || echo "DIFF $(basename $f)"; done | tee $OUT/diff.txt
cmp /tmp/q/cpu/targets.csv /tmp/q/gpu/targets.csv && echo "targets.csv same"
echo "images differing: $(wc -l < $OUT/diff.txt)"
