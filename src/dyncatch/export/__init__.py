"""Deployable policies: a trained run as ONNX graphs plus a JSON description of their inputs.

``export_run(run_dir, out)`` (``bundle.py``) writes ``policy.onnx``, ``predictor.onnx`` for
methods that read a predictor, and ``export.json``; ``graphs.py`` builds the ONNX graphs op
by op from the parameters; ``layout.py`` names every input slot from the code that fills it.
See docs/ecosystem.md.
"""

from dyncatch.export.bundle import export, export_run

__all__ = ["export", "export_run"]
