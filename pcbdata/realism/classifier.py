"""SPEC 2b's joint test: a classifier that tells real boards from level boards.

A gradient-boosted classifier (scikit-learn's histogram one, which takes undefined values)
over the seven statistics, one row per board, trained to tell the two samples apart; the
measure is its 10-fold cross-validated ROC AUC (the mean of the folds' AUCs, stratified
folds). 0.5: not told apart; 1: told apart on every board. Needs scikit-learn
(`pip install 'pcbdata[realism]'`); `pcbdata.realism.noise` gives its floor.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pcbdata.core.errors import UserError
from pcbdata.realism.statistics import STATISTICS, BoardStatistics

#: SPEC 2b: the classifier's cross-validated ROC AUC, at most this.
AUC_TARGET = 0.65
FOLDS = 10


def features(stats: Sequence[BoardStatistics]) -> np.ndarray:
    """One row per board, columns in `STATISTICS` order: pads per net as the board's mean,
    undefined values (no closed outline, no multi-pad part) as NaN."""
    def value(s: BoardStatistics, name: str) -> float:
        v = getattr(s, name)
        if isinstance(v, tuple):
            return sum(v) / len(v) if v else math.nan
        return math.nan if v is None else float(v)

    return np.array([[value(s, name) for name in STATISTICS] for s in stats],
                    dtype=float).reshape(len(stats), len(STATISTICS))


def classifier_auc(real: Sequence[BoardStatistics], ours: Sequence[BoardStatistics],
                   seed: int = 0, importance: bool = True) -> tuple[float, dict[str, float]]:
    """`feature_auc` of two board samples."""
    return feature_auc(features(real), features(ours), seed, importance)


def feature_auc(real: np.ndarray, ours: np.ndarray, seed: int = 0,
                importance: bool = True) -> tuple[float, dict[str, float]]:
    """The 10-fold cross-validated ROC AUC of the classifier telling the rows of `real` from
    those of `ours` (`features` rows; SPEC 2b: equal sizes), folds and model seeded by `seed`,
    and, with `importance`, each statistic's permutation importance (mean AUC drop) on the
    folds' held-out parts (an empty dict without: the AUC is the same)."""
    try:
        from sklearn.ensemble import HistGradientBoostingClassifier
        from sklearn.inspection import permutation_importance
        from sklearn.metrics import roc_auc_score
        from sklearn.model_selection import StratifiedKFold
    except ImportError as exc:  # an optional extra: the package's core does not need it
        raise UserError(f"the classifier test needs scikit-learn (pip install "
                        f"'pcbdata[realism]'): {exc}") from None

    x = np.vstack([real, ours])
    y = np.array([1] * len(real) + [0] * len(ours))
    folds = StratifiedKFold(n_splits=FOLDS, shuffle=True, random_state=seed)
    scores, drops = [], np.zeros(len(STATISTICS))
    for train, test in folds.split(x, y):
        model = HistGradientBoostingClassifier(random_state=seed).fit(x[train], y[train])
        scores.append(roc_auc_score(y[test], model.predict_proba(x[test])[:, 1]))
        if importance:
            drop = permutation_importance(model, x[test], y[test], scoring="roc_auc",
                                          n_repeats=5, random_state=seed)
            drops += drop.importances_mean
    names = dict(zip(STATISTICS, drops / FOLDS, strict=True)) if importance else {}
    return float(np.mean(scores)), {n: float(v) for n, v in names.items()}

