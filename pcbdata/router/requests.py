"""The walkaround router's request and answer, and the mark-obstacles line."""
from __future__ import annotations

from dataclasses import dataclass, field

from pcbdata.router.geometry import (
    Point,
    one_bend_paths,
)


@dataclass(frozen=True)
class RouteRequest:
    net: str
    layer: str
    start: tuple[int, int]
    goal: tuple[int, int]
    width: int
    clearance: int


@dataclass(frozen=True)
class RouteResult:
    path: tuple[tuple[int, int], ...] | None  # start ... goal, octilinear; None = no path
    reason: str  # "" on success; why not otherwise
    stats: dict = field(default_factory=dict)  # method, expanded, checks, nodes, seconds, ...


def mark_obstacles_path(start: Point, goal: Point) -> tuple[Point, ...]:
    """The `mark_obstacles` line: straight if octilinear, else straight then 45 degrees."""
    if start == goal:
        return ((int(start[0]), int(start[1])),)
    return one_bend_paths(start, goal)[0]
