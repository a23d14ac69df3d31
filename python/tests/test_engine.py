"""The engine from Python: round trips, determinism, history, bad input, datasets.

Run with `pytest python/tests` after `maturin develop -m python/Cargo.toml` (or
`pip install ./python`); `.ci/run` does both in a venv.
"""

import os
import pathlib
import subprocess
import threading

import numpy as np
import pytest

import tacsim

REPO = pathlib.Path(__file__).resolve().parents[2]
# The engine's checks run on the half-space preset (the default sensor's dome needs a finer
# contact grid along the square's edge, and its first use builds its table).
HALF_SPACE = "tactip-331-calibrated"
EDGE = (45.0, 0.0, 1.5, 0.0)  # the square's right edge (its middle), 1.5 mm deep


def pressed(pose=EDGE, shape="square"):
    contact = tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), tacsim.Scene(shape))
    contact.press(pose)
    return contact


def test_sensor_presets_and_toml_round_trip(tmp_path):
    assert "square" in tacsim.shapes() and "disk" in tacsim.shapes()
    default = tacsim.Sensor.load()
    assert default.name == "tactip-331-dome" and default.pin_count == 331
    assert "model = \"dome\"" in default.to_toml()
    assert set(tacsim.Sensor.presets()) >= {"tactip-331-calibrated", "tactip-331-edge2d"}
    edge = tacsim.Sensor.load("tactip-331-edge2d")
    assert edge.image_size == 128
    path = tmp_path / "mine.toml"
    path.write_text(edge.to_toml())
    again = tacsim.Sensor.load(str(path))
    assert again.to_toml() == edge.to_toml()
    img = edge.undeformed_image()
    assert img.shape == (128, 128) and img.dtype == np.uint8 and set(np.unique(img)) <= {0, 255}


def test_a_press_deforms_the_image_and_a_lift_restores_it():
    contact = pressed()
    sensor = tacsim.Sensor.load(HALF_SPACE)
    assert contact.in_contact and contact.force_n[2] > 1.0
    assert contact.pose == (45.0, 0.0, 1.5, 0.0, 0.0, 0.0)
    assert (contact.image(128) != sensor.undeformed_image(128)).sum() > 100
    contact.lift()
    assert not contact.in_contact and contact.pose is None
    np.testing.assert_array_equal(contact.image(128), sensor.undeformed_image(128))


def test_the_pressure_field_carries_the_normal_force():
    contact = pressed()
    p, cell_mm = contact.pressure()
    assert p.shape[0] == p.shape[1] and (p >= 0).all()
    # MPa x mm^2 = N; the sensor is untilted, so the normal is the contact frame's.
    assert abs(p.sum() * cell_mm**2 - contact.force_n[2]) < 1e-6 * contact.force_n[2]


def test_a_finer_grid_converges():
    # Pins on the default grid (25 cells over a 5 mm contact disk) against 65 cells, same disk.
    def pins(cells):
        c = tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), tacsim.Scene("disk"), max_depth_mm=1.5, cells=cells)
        c.press((0.0, 0.0, 1.5, 0.0))
        return c.pins_mm(), c.force_n[2]

    (coarse, f_coarse), (fine, f_fine) = pins(25), pins(65)
    # Measured: 0.006 mm and 0.004%; with max_depth_mm = 5 the 25 cells are 2.5x wider: 0.085 mm.
    assert np.abs(coarse - fine).max() < 0.02 and abs(f_coarse - f_fine) < 0.005 * f_fine


def test_pins_in_mm_and_px():
    contact = pressed()
    mm, px = contact.pins_mm(), contact.pins_px(128)
    assert mm.shape == (331, 3) and px.shape == (331, 2)
    assert np.isfinite(px).all() and (px > 0).all() and (px < 128).all()


def test_same_operations_same_bytes_in_threads():
    def run(out, i):
        c = pressed()
        c.slide_to((45.0, 2.0, 1.5, 10.0), step_mm=0.25)
        out[i] = (c.image(128).tobytes(), c.pins_mm().tobytes(), c.force_n.tobytes())

    out = [None] * 3
    threads = [threading.Thread(target=run, args=(out, i)) for i in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert out[0] == out[1] == out[2]


def test_the_same_pose_by_another_path_gives_other_pins():
    # Sliding to the pose leaves the skin sheared (stick/slip history); pressing onto it does not.
    slid = pressed((45.0, -2.0, 1.5, 0.0))
    slid.slide_to(EDGE, step_mm=0.25)
    tapped = pressed(EDGE)
    assert slid.pose == tapped.pose
    assert abs(slid.force_n[1]) > 1.0 and abs(tapped.force_n[1]) < 0.05
    assert np.abs(slid.pins_mm() - tapped.pins_mm()).max() > 0.05


@pytest.mark.parametrize(
    "call, needle",
    [
        (lambda: tacsim.Sensor.load("no-such-sensor"), "neither a file nor a built-in preset"),
        (lambda: tacsim.Scene("cube"), "cube"),
        (lambda: tacsim.Scene("square", friction=5.0), "friction must be in [0, 2]"),
        (lambda: tacsim.Scene("square", pose=(float("nan"), 0.0, 0.0)), "pose must be finite"),
        (lambda: tacsim.Scene(shape="square", obj_path="x.obj"), "exactly one"),
        (lambda: tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), tacsim.Scene("square"), max_depth_mm=100.0), "max_depth_mm"),
        (lambda: tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), tacsim.Scene("square"), cells=2), "cells must be in [5, 129]"),
        (lambda: pressed((45.0, 0.0, 1.5)), "got 3 values"),
        (lambda: pressed((45.0, 0.0, float("inf"), 0.0)), "finite"),
        (lambda: pressed((45.0, 0.0, 30.0, 0.0)), "depth"),
        (lambda: pressed().slide_to(EDGE, step_mm=0.0), "step_mm must be in [0.01, 10]"),
        (lambda: pressed().image(size=4), "size must be in [16, 2048]"),
        (lambda: tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), tacsim.Scene("square")).slide_to(EDGE), "press first"),
    ],
)
def test_bad_input_raises_value_error_naming_the_field(call, needle):
    with pytest.raises(ValueError) as e:
        call()
    assert needle in str(e.value)


def test_a_bad_slide_target_leaves_the_contact_as_it_was():
    contact = pressed()
    before = contact.pins_mm()
    with pytest.raises(ValueError):
        contact.slide_to((45.0, 0.0, 30.0, 0.0))
    assert contact.pose == (45.0, 0.0, 1.5, 0.0, 0.0, 0.0)
    np.testing.assert_array_equal(contact.pins_mm(), before)


def test_an_obj_file_is_a_stimulus(tmp_path):
    scene = tacsim.Scene(obj_path=str(REPO / "shapes" / "disk.obj"), friction=0.3)
    assert scene.names == ["disk"]
    contact = tacsim.Contact(tacsim.Sensor.load(HALF_SPACE), scene)
    contact.press((0.0, 0.0, 1.0, 0.0))
    assert contact.in_contact
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError) as e:
        tacsim.Scene(obj_path=str(bad))
    assert "bad.obj" in str(e.value)
    with pytest.raises(OSError):
        tacsim.Scene(obj_path=str(tmp_path / "missing.obj"))


def tacsim_binary():
    path = os.environ.get("TACSIM_BIN")
    if not path or not os.path.isfile(path):
        pytest.skip("set TACSIM_BIN to the tacsim binary (cargo build) to test datasets; .ci/run does")
    return path


def test_generate_writes_the_same_bytes_as_the_command_line(tmp_path):
    calls = []
    summary = tacsim.generate("quick", str(tmp_path / "py"), threads=1, progress=lambda d, t: calls.append((d, t)))
    assert summary["written"] == summary["images"] > 0 and summary["skipped"] == 0
    assert calls and calls[-1] == (summary["images"], summary["images"]) and len(calls) <= 101
    subprocess.run([tacsim_binary(), "generate", "quick", "--quiet", "--out", str(tmp_path / "cli")], check=True)
    files = lambda d: {p.relative_to(d): p.read_bytes() for p in d.rglob("*") if p.is_file()}  # noqa: E731
    assert files(tmp_path / "py") == files(tmp_path / "cli")
    again = tacsim.generate("quick", str(tmp_path / "py"), resume=True)
    assert again["skipped"] == summary["images"] and again["written"] == 0


def test_generate_refuses_bad_recipes_and_oversized_runs_before_any_work(tmp_path):
    with pytest.raises(ValueError) as e:
        tacsim.generate("no-such-recipe", str(tmp_path / "x"))
    assert "paper, quick" in str(e.value)
    big = tmp_path / "big.toml"
    big.write_text('[[shapes]]\nname = "disk"\n[poses]\nper_shape = 2000\n[taps]\nper_pose = 501\n[slides]\nper_pose = 0\n')
    with pytest.raises(ValueError) as e:
        tacsim.generate(str(big), str(tmp_path / "big"))
    assert "1002000 images" in str(e.value) and "--force" in str(e.value)
    assert not (tmp_path / "big").exists()

    def stop(done, total):
        raise RuntimeError("stop")

    with pytest.raises(RuntimeError):
        tacsim.generate("quick", str(tmp_path / "cb"), progress=stop)


def test_a_generated_dataset_as_arrays(tmp_path):
    out = tmp_path / "quick"
    subprocess.run([tacsim_binary(), "generate", "quick", "--quiet", "--out", str(out)], check=True)
    data = tacsim.Dataset(str(out))
    assert len(data) > 0 and data.columns[0] == "pose_x" and len(data.columns) == 12
    images, labels = data.samples("train", "tap")
    assert images.shape[1:] == (data.image_size, data.image_size) and images.dtype == np.uint8
    assert labels.shape == (images.shape[0], 12) and np.isfinite(labels).all()
    taps, slides, tap_labels, slide_labels = data.true_pairs("train")
    assert taps.shape == slides.shape and len(taps) > 0
    # A true pair is one pose: the same lateral labels.
    np.testing.assert_allclose(tap_labels[:, :2], slide_labels[:, :2])
    assert data.reference().shape == (data.image_size, data.image_size)
    with pytest.raises(ValueError):
        data.samples("training")
    with pytest.raises(OSError):
        tacsim.Dataset(str(tmp_path / "nothing"))


def test_sim2real_runs_the_command_line_tool_and_says_what_is_missing(tmp_path, monkeypatch):
    monkeypatch.delenv("TACSIM_BIN", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(FileNotFoundError) as e:
        tacsim.sim2real(tmp_path / "lab", tmp_path / "out")
    assert "cargo install --path ." in str(e.value)
    monkeypatch.undo()
    # The tool's own message comes back, before any work: not a lab folder.
    with pytest.raises(RuntimeError) as e:
        tacsim.sim2real(tmp_path / "no-lab", tmp_path / "out", finetune=[25, "all"], tacsim_bin=tacsim_binary())
    assert "lab folder" in str(e.value)
    assert not (tmp_path / "out").exists()
    # `input` reaches the tool's flag: motion with a threshold is refused, before any work.
    with pytest.raises(RuntimeError) as e:
        tacsim.sim2real(tmp_path / "no-lab", tmp_path / "out", input="motion", extra=["--threshold", "128"],
                        tacsim_bin=tacsim_binary())
    assert "--input motion" in str(e.value)
    assert not (tmp_path / "out").exists()
    # `motion_field` reaches its flag: without `input="motion"` it is refused, before any work.
    with pytest.raises(RuntimeError) as e:
        tacsim.sim2real(tmp_path / "no-lab", tmp_path / "out", motion_field=1.0, tacsim_bin=tacsim_binary())
    assert "--motion-field" in str(e.value)
    assert not (tmp_path / "out").exists()
    # `turns` reaches its flag: without `input="motion"` it is refused, before any work.
    with pytest.raises(RuntimeError) as e:
        tacsim.sim2real(tmp_path / "no-lab", tmp_path / "out", turns=8, tacsim_bin=tacsim_binary())
    assert "--turns" in str(e.value)
    assert not (tmp_path / "out").exists()
    # `edge_frame` reaches its flag: without `input="motion"` it is refused, before any work.
    with pytest.raises(RuntimeError) as e:
        tacsim.sim2real(tmp_path / "no-lab", tmp_path / "out", edge_frame=True, tacsim_bin=tacsim_binary())
    assert "--edge-frame" in str(e.value)
    assert not (tmp_path / "out").exists()
