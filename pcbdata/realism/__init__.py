"""Realism measurement of the realistic family (SPEC section 2b): how close generated boards are
to the real boards of a D3 tier.

Modules: `statistics` (the seven board statistics read from `.kicad_pcb` files, and the KS
distance), `classifier` (the joint test: a classifier's cross-validated ROC AUC), `noise`
(what sampling alone makes of the distances and of the classifier test's AUC), `external`
(real PCBench boards of a tier's size beyond D3). `bench/bench_realism.py`
uses them; the calibration halves ship as `pcbdata/resources/realism/calibration.json`.
"""
