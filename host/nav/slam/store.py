"""The mapper's pose graph saved beside the map, and loaded to go on mapping
(:func:`save_graph`, :func:`load_graph`), as slam_toolbox serialises its pose graph.

One NumPy ``.npz`` file (``built_map.graph.npz`` beside ``built_map.yaml``): every node's pose
in the graph, odometry pose, LiDAR mount, travel and scan (time, angles, ranges, range limits,
the scans' arrays laid end to end with their lengths), every edge (nodes, measured relative
pose, standard deviations and spread, whether it closes a loop), the mapping parameters that
shape the map (resolution, occupancy threshold, minimum observations, ranges) and a format
version. The map is the scans written at the nodes' poses, so loading writes them again and the
map comes back cell for cell; the mapper then goes on from the last node: its next scan's
odometry is taken relative to that node's, so a robot that starts again where the graph ended
(the map frame) continues the same map.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jackson.common.errors import JacksonError
from jackson.host.nav.slam.graph import Edge
from jackson.host.nav.slam.loops import Node
from jackson.host.nav.slam.mapper import Mapper, MappingConfig
from jackson.host.nav.types import Pose2D, Scan

GRAPH_FORMAT = 2  # 2 added the edges' spread; a format 1 file loads with none
READABLE_FORMATS = (1, 2)
GRAPH_SUFFIX = ".graph.npz"  # beside the map's YAML: built_map.yaml -> built_map.graph.npz


class GraphFileError(JacksonError, ValueError):
    """A pose-graph file that cannot be read: one line naming the file and what is wrong."""


def graph_path(map_yaml: Path) -> Path:
    """Where the graph of the map ``map_yaml`` is saved."""
    return map_yaml.with_name(map_yaml.stem + GRAPH_SUFFIX)


def save_graph(mapper: Mapper, path: Path) -> None:
    """Write the mapper's nodes, scans and edges to ``path`` (an ``.npz``)."""
    nodes = mapper.nodes
    cfg = mapper.config
    lengths = np.array([n.scan.angles_rad.size for n in nodes], np.int64)
    empty = np.zeros(0, np.float64)
    edges = mapper.graph.edges
    np.savez_compressed(
        path,
        format=np.array(GRAPH_FORMAT),
        settings=np.array(
            [cfg.resolution_m, cfg.occupancy_threshold, cfg.min_observations, cfg.max_range_m]
        ),
        poses=mapper.graph.poses(),
        odom=np.array([(n.odom.x, n.odom.y, n.odom.yaw) for n in nodes]).reshape(-1, 3),
        mount=np.array([(n.mount.x, n.mount.y, n.mount.yaw) for n in nodes]).reshape(-1, 3),
        travel=np.array([n.travel_m for n in nodes], np.float64),
        scan_t=np.array([n.scan.t_s for n in nodes], np.float64),
        scan_limits=np.array([(n.scan.range_min_m, n.scan.range_max_m) for n in nodes]).reshape(
            -1, 2
        ),
        scan_lengths=lengths,
        angles=np.concatenate([n.scan.angles_rad for n in nodes]) if nodes else empty,
        ranges=np.concatenate([n.scan.ranges_m for n in nodes]) if nodes else empty,
        edge_nodes=np.array([(e.i, e.j) for e in edges], np.int64).reshape(-1, 2),
        edge_z=np.array([(e.z.x, e.z.y, e.z.yaw) for e in edges]).reshape(-1, 3),
        edge_sigma=np.array([(e.sigma_m, e.sigma_rad) for e in edges]).reshape(-1, 2),
        edge_loop=np.array([e.loop for e in edges], np.bool_),
        edge_spread=np.array([e.spread for e in edges], np.float64).reshape(-1, 3),
    )


def load_graph(path: Path, config: MappingConfig | None = None) -> Mapper:
    """A mapper holding the graph saved in ``path``, its map written again, ready to go on.

    Raises
    ------
    GraphFileError
        The file is missing, not a graph file, of another format, or made with another
        resolution or occupancy rule than ``config``'s.
    """
    config = MappingConfig() if config is None else config
    try:
        with np.load(path) as f:
            data = {k: f[k] for k in f.files}
    except (OSError, ValueError, EOFError) as exc:
        raise GraphFileError(f"{path}: not a pose-graph file ({exc})") from exc
    if int(data.get("format", -1)) not in READABLE_FORMATS:
        raise GraphFileError(
            f"{path}: not a pose-graph file of format {' or '.join(map(str, READABLE_FORMATS))}"
        )
    res, threshold, min_obs, _ = (float(v) for v in data["settings"])
    made = (res, threshold, int(min_obs))
    if made != (config.resolution_m, config.occupancy_threshold, config.min_observations):
        raise GraphFileError(
            f"{path}: made with resolution {res} m, occupancy threshold {threshold}, "
            f"{int(min_obs)} observations; map it again or use those settings"
        )
    mapper = Mapper(config)
    ends = np.cumsum(data["scan_lengths"])
    starts = ends - data["scan_lengths"]
    for k, pose in enumerate(data["poses"]):
        a, b = int(starts[k]), int(ends[k])
        lo, hi = (float(v) for v in data["scan_limits"][k])
        scan = Scan(float(data["scan_t"][k]), data["angles"][a:b], data["ranges"][a:b], lo, hi)
        mapper.graph.add_node(Pose2D(*(float(v) for v in pose)))
        mapper.nodes.append(
            Node(
                scan,
                Pose2D(*(float(v) for v in data["mount"][k])),
                Pose2D(*(float(v) for v in data["odom"][k])),
                float(data["travel"][k]),
            )
        )
    spreads = data.get("edge_spread", np.zeros((len(data["edge_nodes"]), 3)))
    for (i, j), z, (sm, sr), loop, (sxx, sxy, syy) in zip(
        data["edge_nodes"],
        data["edge_z"],
        data["edge_sigma"],
        data["edge_loop"],
        spreads,
        strict=True,
    ):
        z_pose = Pose2D(*(float(v) for v in z))
        spread = (float(sxx), float(sxy), float(syy))
        mapper.graph.add_edge(
            Edge(int(i), int(j), z_pose, float(sm), float(sr), bool(loop), spread=spread)
        )
    mapper.resume()
    return mapper
