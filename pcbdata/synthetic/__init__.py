"""The synthetic pipeline: generated boards (D1, D2) written into a set with KiCad checks of a
sample, resumable, and their manifest (`build`)."""
