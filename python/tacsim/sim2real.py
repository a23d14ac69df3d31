"""Sim-to-real from Python: runs ``tacsim sim2real``, the command-line tool that holds the
networks (the package has no burn inside), and returns its reports as dictionaries.

>>> import tacsim
>>> reports = tacsim.sim2real("../shared/data/real-tactip-edge2d-full", "work",
...                           finetune=[25, 50, 100, 200, 400, "all"])  # doctest: +SKIP
>>> reports["finetune"]["labels"][0]["labels_saved"]                    # doctest: +SKIP

The tool is found as ``tacsim_bin``, else ``$TACSIM_BIN``, else ``tacsim`` on the ``PATH``
(``cargo install --path .`` in the repository puts it there). The work folder resumes as the
command's does: a finished stage, run or curve point is read back.
"""

import json
import os
import shutil
import subprocess
from pathlib import Path


def sim2real(real, out, *, recipe=None, sensor=None, sim=None, size=None, epochs=None, seed=None,
             finetune=None, finetune_seeds=None, finetune_min_steps=None, finetune_lr_scale=None,
             finetune_sim_share=None, input=None, motion_field=None, turns=None, edge_frame=False,  # noqa: A002
             match_motion=False, axis_offset=False, report=None, extra=(), tacsim_bin=None):
    """Runs ``tacsim sim2real --real REAL --out OUT`` with the options given (the flags of the
    same names; ``finetune`` a list of sample counts and ``"all"``; ``input`` ``"pins"`` or
    ``"motion"``, what the networks read; ``motion_field`` with ``"motion"``, the part of the
    pin field tracked, a fraction of the image's half-side in [0.2, 1]; ``turns`` with
    ``"motion"``, how many turns of each lab image the simulator-trained network's readings
    average, 1 to 64; ``edge_frame=True`` with ``"motion"``, the lateral and depth read by a second
    network from each image turned into the edge's frame, by the real-trained network and the
    fine-tuning curve's arms too;
    ``match_motion=True`` with it, those images matched pixel by pixel to the simulated ones'
    mean and spread; ``axis_offset=True``, the lab sensor's axis offset fitted into the label
    map: the lateral's ``a cos + b sin`` of the yaw read) and returns
    ``{"report": ..., "finetune": ...}``: ``report.json`` and, with ``finetune``,
    ``finetune.json`` (``None`` without). Raises ``FileNotFoundError`` where no tool is found
    and ``RuntimeError`` with the tool's message where it fails."""
    binary = tacsim_bin or os.environ.get("TACSIM_BIN") or shutil.which("tacsim")
    if not binary or not os.path.isfile(binary):
        raise FileNotFoundError(
            "tacsim.sim2real needs the tacsim command-line tool: run `cargo install --path .` in the "
            "repository, or set TACSIM_BIN (or tacsim_bin=) to the binary"
        )
    args = [binary, "sim2real", "--real", str(real), "--out", str(out), "-q"]
    flags = {
        "--recipe": recipe, "--sensor": sensor, "--sim": sim, "--size": size, "--epochs": epochs,
        "--seed": seed, "--finetune-seeds": finetune_seeds, "--finetune-min-steps": finetune_min_steps,
        "--finetune-lr-scale": finetune_lr_scale, "--finetune-sim-share": finetune_sim_share,
        "--input": input, "--motion-field": motion_field, "--turns": turns, "--report": report,
    }
    for flag, value in flags.items():
        if value is not None:
            args += [flag, str(value)]
    if edge_frame:
        args += ["--edge-frame"]
    if match_motion:
        args += ["--match-motion"]
    if axis_offset:
        args += ["--axis-offset"]
    if finetune is not None:
        args += ["--finetune", ",".join(str(k) for k in finetune)]
    args += [str(a) for a in extra]
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(done.stderr.strip() or f"tacsim sim2real exited with {done.returncode}")
    folder = Path(report if report is not None else out)
    read = lambda name: json.loads((folder / name).read_text())  # noqa: E731
    return {"report": read("report.json"), "finetune": read("finetune.json") if finetune is not None else None}
