"""The road network of a driving run, drawn once as the background of every frame.

The OpenDRIVE map is read with Scenic's road network into shapely layers (roads, junctions,
sidewalks, lane markings, ...), which matplotlib's Agg canvas draws, antialiased, at the scale of
the chosen :class:`View`. Coordinates are map coordinates [m] (x east, y north).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from regen import media
from regen.core.scenario import Scenario
from regen.core.trace import Trace
from regen.driving.world.setting import DrivingWorld
from regen.errors import DependencyNotInstalled, RegenError

log = logging.getLogger(__name__)

__all__ = ["MapLayers", "View", "background", "map_artists", "map_layers", "polygons",
           "read_map_layers"]

FRAME_W, FRAME_H = 640, 480  # output frame [px]
CAPTION_H = media.CAPTION_H  # caption band below the map [px]
MAP_H = FRAME_H - CAPTION_H  # map area [px]
DPI = 100  # [dots/inch] of the figure the map is drawn in; widths of lines are in points

# Colors (RGB) of the ground.
GRASS = (226, 231, 218)
ROAD = (86, 88, 94)
JUNCTION = (98, 100, 108)
SIDEWALK = (200, 196, 188)
CROSSING = (150, 150, 156)
SHOULDER = (120, 122, 126)
MARK_WHITE = (244, 244, 244)
MARK_YELLOW = (240, 196, 40)


@dataclass(frozen=True)
class MapLayers:
    """Shapely polygons and polylines [m] of a road network, free of Scenic objects."""

    roads: tuple
    intersections: tuple
    sidewalks: tuple
    crossings: tuple
    shoulders: tuple
    lane_lines: tuple  # dashed white, between lanes of one direction
    curb_lines: tuple  # solid white, outer edges of the driving lanes
    center_lines: tuple  # solid yellow, between opposite directions


def _coords(polyline) -> np.ndarray:
    return np.asarray(polyline.lineString.coords)[:, :2]


def _markings(road) -> tuple[list, list, list]:
    """Lane lines of one road, classified by which lanes share them.

    Scenic does not order lanes the same way in both directions, so edges are matched by
    position: an edge two lanes of one direction share is a dashed lane line, one shared by
    opposite directions is the yellow centre line, one that only one lane has is the curb edge.
    """
    owners: dict[tuple[float, float], list] = {}
    lines: dict[tuple[float, float], np.ndarray] = {}
    for group in road.laneGroups:
        for lane in group.lanes:
            for edge in (lane.leftEdge, lane.rightEdge):
                mid = edge.lineString.interpolate(0.5, normalized=True)
                key = (round(mid.x * 2) / 2, round(mid.y * 2) / 2)  # 0.5 m buckets
                owners.setdefault(key, []).append(group)
                lines.setdefault(key, _coords(edge))
    lane_lines, curbs, centers = [], [], []
    for key, groups in owners.items():
        if len(groups) == 1:
            curbs.append(lines[key])
        elif all(g is groups[0] for g in groups):
            lane_lines.append(lines[key])
        else:
            centers.append(lines[key])
    return lane_lines, curbs, centers


@lru_cache(maxsize=8)
def _load_layers(path: str, mtime: float) -> MapLayers:  # mtime: a changed file is reloaded
    try:
        from scenic.domains.driving.roads import Network
    except ModuleNotFoundError as exc:
        raise DependencyNotInstalled("scenic", "driving", "reading OpenDRIVE maps for pictures") from exc
    net = Network.fromFile(path)
    lane_lines, curb_lines, center_lines = [], [], []
    for road in net.roads:  # ordinary roads only: no markings inside junctions
        lane_lines_r, curbs_r, centers_r = _markings(road)
        lane_lines += lane_lines_r
        curb_lines += curbs_r
        center_lines += centers_r
    return MapLayers(
        roads=tuple(r.polygon for r in net.roads),
        intersections=tuple(i.polygon for i in net.intersections),
        sidewalks=tuple(s.polygon for s in net.sidewalks),
        crossings=tuple(c.polygon for c in net.crossings),
        shoulders=tuple(s.polygon for s in net.shoulders),
        lane_lines=tuple(lane_lines),
        curb_lines=tuple(curb_lines),
        center_lines=tuple(center_lines),
    )


def _map_path(scenario: Scenario, trace: Trace) -> Path | None:
    raw = trace.meta.get("map_path")
    if isinstance(raw, str) and raw:
        path = Path(raw)
        if path.is_file():
            return path
        log.warning("map file %s recorded in the trace does not exist; trying the map name", path)
    name = trace.meta.get("map") or DrivingWorld.of(scenario).map
    if not isinstance(name, str) or not name:
        return None
    try:
        from regen.driving.world.maps import ensure_map

        return ensure_map(name)
    except (ImportError, RegenError) as exc:
        log.warning("cannot get map %r for the pictures: %s", name, exc)
        return None


def map_layers(scenario: Scenario, trace: Trace) -> MapLayers | None:
    """The road network the trace ran on, or None (drawn as plain ground) if it cannot be read."""
    path = _map_path(scenario, trace)
    if path is None:
        return None
    return read_map_layers(path)


def read_map_layers(path: Path) -> MapLayers | None:
    """The road network of the OpenDRIVE file ``path`` (cached per file and modification time),
    or None, with a warning, when it cannot be read."""
    try:
        return _load_layers(str(path.resolve()), path.stat().st_mtime)
    except DependencyNotInstalled:
        raise
    except Exception as exc:  # noqa: BLE001 - Scenic's parser raises many types; a bad map
        # must not cost the run its pictures, so draw the actors on plain ground and say why
        log.warning("cannot read map %s (%s: %s); drawing without roads", path, type(exc).__name__, exc)
        return None


@dataclass(frozen=True)
class View:
    """Maps world [m] to background pixels and picks the map window of each frame."""

    scale: float  # [px/m]
    x0: float  # world x [m] of the background's left edge
    y1: float  # world y [m] of the background's top edge
    width: int  # background size [px]
    height: int
    follow: str | None  # name of the followed actor, None for a fixed view

    def to_px(self, x, y):
        return (np.asarray(x) - self.x0) * self.scale, (self.y1 - np.asarray(y)) * self.scale

    def window(self, cx: float, cy: float) -> tuple[int, int]:
        """Top-left background pixel of the map window centred on (cx, cy) [m], kept inside."""
        px, py = self.to_px(cx, cy)
        left = int(round(float(px) - FRAME_W / 2))
        top = int(round(float(py) - MAP_H / 2))
        return (min(max(left, 0), max(self.width - FRAME_W, 0)),
                min(max(top, 0), max(self.height - MAP_H, 0)))


def _poly_path(poly):
    from matplotlib.path import Path as MplPath

    rings = [poly.exterior, *poly.interiors]
    return MplPath.make_compound_path(*[MplPath(np.asarray(r.coords)[:, :2], closed=True)
                                        for r in rings])


def polygons(geom) -> list:
    """The polygons of a shapely area: its parts when it has several, none when it is empty."""
    if geom is None or geom.is_empty:
        return []
    return list(geom.geoms) if hasattr(geom, "geoms") else [geom]


def background(layers: MapLayers | None, view: View) -> Image.Image:
    """The static map at the view's scale, drawn once (antialiased) with matplotlib's Agg canvas.

    The shapes are placed on the figure itself through the transform an axes spanning it with
    the view's limits would use (the same pixels): an axes' ticks, spines and data limits,
    which nothing here shows, cost more than drawing the map.
    """
    if layers is None:
        img = Image.new("RGB", (view.width, view.height), GRASS)
        _grid(img, view)
        return img
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.transforms import Bbox, BboxTransformFrom, BboxTransformTo

    fig = Figure(figsize=(view.width / DPI, view.height / DPI), dpi=DPI, facecolor=_rgb01(GRASS))
    canvas = FigureCanvasAgg(fig)
    x1, y0 = view.x0 + view.width / view.scale, view.y1 - view.height / view.scale
    limits = Bbox([[view.x0, y0], [x1, view.y1]])
    for artist in map_artists(layers, view, BboxTransformFrom(limits) + BboxTransformTo(fig.bbox)):
        fig.add_artist(artist)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    return Image.fromarray(rgba[..., :3].copy(), "RGB")


def map_artists(layers: MapLayers, view: View, transform) -> list:
    """The matplotlib shapes of the map, bottom first, placed by ``transform`` ([m] -> pixels of
    a :data:`DPI` figure): ground areas, then dashed lane lines, white curbs, yellow centres."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import PathPatch

    out = []
    for group, color in ((layers.sidewalks, SIDEWALK), (layers.shoulders, SHOULDER),
                         (layers.roads, ROAD), (layers.intersections, JUNCTION),
                         (layers.crossings, CROSSING)):
        for geom in group:
            for poly in polygons(geom):
                out.append(PathPatch(_poly_path(poly), facecolor=_rgb01(color), edgecolor=_rgb01(color),
                                     linewidth=0.5, transform=transform))
    pt_per_m = view.scale * 72.0 / DPI  # line widths and dashes are in points
    mark_w = max(0.75, 0.15 * pt_per_m)
    dash = (3.0 * pt_per_m / mark_w, 6.0 * pt_per_m / mark_w)  # 3 m dashes, 6 m gaps
    for lines, color, width, dashes in ((layers.lane_lines, MARK_WHITE, mark_w, dash),
                                        (layers.curb_lines, MARK_WHITE, mark_w, None),
                                        (layers.center_lines, MARK_YELLOW, mark_w * 1.5, None)):
        for line in lines:
            mark = Line2D(line[:, 0], line[:, 1], color=_rgb01(color), lw=width, transform=transform)
            if dashes is not None:
                mark.set_dashes(dashes)
            out.append(mark)
    return out


def _grid(img: Image.Image, view: View) -> None:
    """A 10 m grid on plain ground, so distances stay readable without a map."""
    draw = ImageDraw.Draw(img)
    step = 10.0
    x_end = view.x0 + view.width / view.scale
    y_end = view.y1 - view.height / view.scale
    for gx in np.arange(math.ceil(view.x0 / step) * step, x_end, step):
        px, _ = view.to_px(gx, 0)
        draw.line([(float(px), 0), (float(px), view.height)], fill=(210, 216, 202))
    for gy in np.arange(math.ceil(y_end / step) * step, view.y1, step):
        _, py = view.to_px(0, gy)
        draw.line([(0, float(py)), (view.width, float(py))], fill=(210, 216, 202))


def _rgb01(c: tuple[int, int, int]) -> tuple[float, float, float]:
    return (c[0] / 255, c[1] / 255, c[2] / 255)
