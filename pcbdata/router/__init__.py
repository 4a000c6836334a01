"""pcbdata's geometric router: octilinear paths on plain integer-nanometre copper.

Pure geometry (shapely and numpy; no KiCad, no Gymnasium): the routing environment asks it for
paths and KiCad judges them, and it can be used on a board without the environment:

>>> from pcbdata.router import BoardGeometry, CopperItem, RouteRequest, WalkaroundRouter
>>> router = WalkaroundRouter(BoardGeometry(outline=..., copper=(...), edge_clearance=300_000))
>>> result = router.route(RouteRequest(net="NET1", layer="F.Cu", start=(..), goal=(..),
...                                    width=300_000, clearance=300_000))
>>> result.path  # (start, ..., goal) in nm, or None with result.reason

- `geometry`: the copper records (`CopperItem`, `BoardGeometry`) and their exact shapes.
- `requests`: a route request and its answer, and the mark-obstacles line;
- `walkaround`: the walkaround router (keeps clearance to every other net and to the edge),
  over `clearance` (items' exact shapes, a layer's index, a request's rules) and `search`
  (the A* over octagon corners), with `ray_screen` (closed-form ray bounds);
- `layered`: a search over every layer at once with vias as moves inside it, and `soft`:
  copper such a search may cross at a price;
- `shove`: push_n_shove's plan (other nets' tracks taken up and rerouted around a path);
- `negotiate`: the whole board planned at once, with rip-up and reroute, over `connections`
  (the minimum spanning trees of the nets' pad clusters).
"""
from pcbdata.router.geometry import BoardGeometry, CopperItem, Point
from pcbdata.router.requests import RouteRequest, RouteResult, mark_obstacles_path
from pcbdata.router.shove import ShovePlan, plan
from pcbdata.router.walkaround import WalkaroundRouter

__all__ = ["BoardGeometry", "CopperItem", "Point", "RouteRequest", "RouteResult", "ShovePlan",
           "WalkaroundRouter", "mark_obstacles_path", "plan"]
