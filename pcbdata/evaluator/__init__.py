"""The evaluator: scores any routed board with the benchmark's engine-checked metrics (SPEC 4).

- `score(instance, routed)`: one routed `.kicad_pcb` against an instance directory -> record.
- `Evaluator`: the same with a long-lived pool of KiCad workers (for RL loops and agents).
- `evaluate_set(...)`: a whole submission with the @k protocol and reports (`pcbdata eval`).
- `metrics`, `integrity`: the pure math, importable without KiCad.
"""
from pcbdata.evaluator.metrics import DEFAULT_WEIGHTS, Weights
from pcbdata.evaluator.runs import evaluate_set, markdown_table
from pcbdata.evaluator.scorer import EVALUATOR_VERSION, Evaluator, score

__all__ = ["EVALUATOR_VERSION", "Evaluator", "score", "DEFAULT_WEIGHTS", "Weights",
           "evaluate_set", "markdown_table"]
