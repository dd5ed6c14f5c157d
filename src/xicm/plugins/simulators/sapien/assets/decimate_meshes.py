"""One-off asset preparation: decimate the Panda's visual meshes for fast CPU rendering.

The original ManiSkill/Franka visual meshes have ~155k triangles; Mesa's lavapipe renders
five 128 px cameras about 6 times a second with them, ~3x faster with 15 % of the triangles
(the look is nearly identical). Run once, from the unpacked mani-skill wheel:

    pip install --target /tmp/tools trimesh fast-simplification
    PYTHONPATH=/tmp/tools python decimate_meshes.py SRC_VISUAL_DIR DST_VISUAL_DIR 0.15

Meshes with fewer than 1000 triangles (the fingers) are copied unchanged. Materials (base
colours) are kept; vertices are welded before simplifying (the GLBs store them per face).
"""

import glob
import os
import shutil
import sys

import fast_simplification
import numpy as np
import trimesh


def main(src_dir: str, out_dir: str, keep: float) -> None:
    for path in sorted(glob.glob(os.path.join(src_dir, "*.glb"))):
        scene = trimesh.load(path)
        if all(len(g.faces) <= 1000 for g in scene.geometry.values()):
            shutil.copy(path, out_dir)
            print(f"{os.path.basename(path)}: copied")
            continue
        out = trimesh.Scene()
        before = after = 0
        for node in scene.graph.nodes_geometry:
            transform, name = scene.graph[node]
            geom = scene.geometry[name]
            before += len(geom.faces)
            if len(geom.faces) > 1000:
                welded = trimesh.Trimesh(geom.vertices, geom.faces, process=True)
                welded.merge_vertices(merge_tex=True, merge_norm=True)
                points, faces = fast_simplification.simplify(
                    np.asarray(welded.vertices, np.float32), np.asarray(welded.faces), target_reduction=1 - keep
                )
                mesh = trimesh.Trimesh(points, faces, process=False)
                mesh.visual = trimesh.visual.TextureVisuals(material=geom.visual.material)
            else:
                mesh = geom
            after += len(mesh.faces)
            out.add_geometry(mesh, node_name=node, geom_name=name, transform=transform)
        data = out.export(file_type="glb")
        with open(os.path.join(out_dir, os.path.basename(path)), "wb") as f:
            f.write(data)
        print(f"{os.path.basename(path)}: {before} -> {after} triangles, {len(data) // 1024} KB")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]))
