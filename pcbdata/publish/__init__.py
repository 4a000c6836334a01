"""Publication of built board sets as Hugging Face datasets (SPEC section 5).

- `publish_set(root, configs)`: parquet shards, pictures and the dataset card, in place.
- `verify_published(root, manifest)`: the rows against the manifest (list of problems).
- `load(config, split, root)`: a `datasets.Dataset`; `iter_boards`, `row_files`,
  `materialize_row` and `materialize`: rows back to KiCad files.
- `push(root, repo)`: upload to the Hugging Face Hub.
"""
from pcbdata.publish.audit import verify_published
from pcbdata.publish.loading import (
                                     BoardOnDisk,
                                     iter_boards,
                                     load,
                                     materialize,
                                     materialize_row,
                                     row_files,
)
from pcbdata.publish.publisher import publish_set
from pcbdata.publish.push import push

__all__ = ["publish_set", "verify_published", "load", "iter_boards", "row_files",
           "materialize_row", "materialize", "BoardOnDisk", "push"]
