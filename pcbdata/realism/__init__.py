"""Realism measurement of the realistic family (SPEC section 2b): how close generated boards are
to the real boards of a D3 tier.

Modules: `statistics` (the seven board statistics read from `.kicad_pcb` files, and the KS
distance), `noise` (what sampling alone makes of the distances and the classifier test's
floor), `external` (real PCBench boards of a tier's size beyond D3). `bench/bench_realism.py`
uses them; the calibration halves ship as `pcbdata/resources/realism/calibration.json`.
"""
