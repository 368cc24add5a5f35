"""Shared bits of the example scripts: argument parsing, loading, the camera.

Not part of lodkit: each script imports it from its own directory.
"""
from __future__ import annotations

import argparse

import lodkit
import lodkit.render as lr
from lodkit.demo import demo_mesh


def parser(description: str) -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("mesh", nargs="?", help="a mesh file (PLY, OBJ, OFF, STL, GLB); default: lodkit's demo surface")
    ap.add_argument("--png", metavar="OUT.png", help="no window: write the picture to this PNG file")
    ap.add_argument("--size", default="320x240", help="size of each panel in the PNG, WxH (default 320x240)")
    ap.add_argument("--demo-faces", type=int, default=20_000, help="faces of the demo surface (default 20000)")
    ap.add_argument("--up", choices=("y", "z"), help="the model's up axis (default: z for the demo surface, else y)")
    ap.add_argument("--view", metavar="AZ,EL", help="camera azimuth and elevation in degrees (default 30,20; "
                    "-30,35 for the demo surface)")
    return ap


def load(args) -> tuple[lodkit.Mesh, str]:
    """The mesh to show and its name."""
    if args.mesh:
        mesh = lodkit.load(args.mesh)
        return mesh, args.mesh.replace("\\", "/").rsplit("/", 1)[-1]
    return demo_mesh(args.demo_faces), "demo surface"


def panel_size(args) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise SystemExit(f"--size must look like 320x240, got {args.size!r}") from None
    return w, h


def camera(args, mesh: lodkit.Mesh, width: int, height: int) -> lr.Camera:
    """One camera for every panel, framing the input mesh."""
    up = args.up or ("y" if args.mesh else "z")
    az, el = (30.0, 20.0) if args.mesh else (-30.0, 35.0)
    if args.view:
        try:
            az, el = (float(v) for v in args.view.split(","))
        except ValueError:
            raise SystemExit(f"--view must look like 30,20, got {args.view!r}") from None
    return lr.Camera.fit(mesh, width, height, up=up, azimuth=az, elevation=el)


def open3d_mesh(mesh: lodkit.Mesh, colors=None):
    """An Open3D TriangleMesh with vertex normals (for lit display) and optional colours."""
    import numpy as np
    import open3d as o3d

    m = mesh.to_open3d()
    m.compute_vertex_normals()
    if colors is not None:
        m.vertex_colors = o3d.utility.Vector3dVector(np.ascontiguousarray(colors, dtype=np.float64))
    elif not m.has_vertex_colors():
        m.paint_uniform_color(lr.DEFAULT_COLOR)
    return m
