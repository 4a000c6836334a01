"""Policy checkpoints: a small torch file with the weights, the network's size and a record
of how it was made; the shipped one lies in `pcbdata/resources/policy/`."""
from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import torch

from pcbdata.core.errors import UserError
from pcbdata.learn.policy import SetPolicy

SHIPPED = "d2.pt"
#: The network's inputs and layers; a checkpoint of another format cannot be read.
FORMAT = 2


def shipped_path() -> Path:
    return Path(str(resources.files("pcbdata.resources") / "policy" / SHIPPED))


def save_policy(policy: SetPolicy, path: Path, record: dict) -> None:
    """Written to a temporary name and renamed, so a kill leaves the old file or the new."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    state = {k: v.detach().cpu() for k, v in policy.state_dict().items()}
    torch.save({"format": FORMAT, "dim": policy.dim, "state": state, "record": record}, tmp)
    os.replace(tmp, path)


def load_policy(path: Path | str | None = None, device: torch.device | None = None
                ) -> tuple[SetPolicy, dict]:
    """(policy in eval mode, its record); None: the shipped checkpoint."""
    path = Path(path) if path is not None else shipped_path()
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
        if data.get("format") != FORMAT:
            raise UserError(f"{path}: a policy checkpoint of format {data.get('format')}, "
                            f"this pcbdata reads format {FORMAT} (other inputs and layers): "
                            "train it again with this version")
        policy = SetPolicy(dim=int(data["dim"]))
        policy.load_state_dict(data["state"])
    except FileNotFoundError:
        raise UserError(f"{path}: no such checkpoint") from None
    except UserError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable or foreign file
        raise UserError(f"{path}: not a pcbdata policy checkpoint ({exc})") from None
    return policy.to(device or torch.device("cpu")).eval(), dict(data.get("record", {}))
