"""``dyncatch export RUN --out DIR``: a trained run as ONNX files (``dyncatch.export``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import tyro

from dyncatch.rl.methods import MethodName


@dataclasses.dataclass(frozen=True)
class ExportCmd:
    """Export a trained run as ONNX graphs and export.json, runnable without dyncatch."""

    run: tyro.conf.Positional[Path]
    """A run folder written by dyncatch train."""
    out: Path
    """Folder to write policy.onnx, predictor.onnx (predictor methods) and export.json to."""
    as_method: MethodName | None = None
    """Export the run as a method that reuses its policy (sp_fp for a gt_rl run)."""
    predictor: Path | None = None
    """Predictor checkpoint, overriding the one the run was trained with (needed for sp_fp)."""


def run_export(cmd: ExportCmd) -> dict:
    # Imported here: the export needs onnx, which no other command loads.
    from dyncatch.export import export_run
    from dyncatch.utils.files import check_out_dir

    check_out_dir(cmd.out)
    manifest = export_run(cmd.run, cmd.out, cmd.as_method, cmd.predictor)
    graphs = [manifest["policy"]] + ([manifest["predictor"]] if manifest.get("predictor") else [])
    for graph in graphs:
        shapes = ", ".join(f"{i['name']} {tuple(i['shape'])}" for i in graph["inputs"])
        print(f"{cmd.out / graph['file']}: {shapes}")
    print(f"{cmd.out / 'export.json'}: {manifest['method']} input layout, rates, versions")
    return manifest
