"""Renderer tests: pictures are checked against projections computed here, not by eye."""
import math

import numpy as np
import pytest
import trimesh
from PIL import Image

from grammarkit.errors import ShapeError
from grammarkit.geometry.camera import Camera
from grammarkit.geometry.render import LineStyle, prepare, rasterize, render, save_image

SIZE = (256, 256)


def pinhole(points, pitch, yaw, fov, target, distance, size):
    """An independent perspective projection (camera on the -y side at yaw 0, z up)."""
    p, y = math.radians(pitch), math.radians(yaw)
    target = np.asarray(target, float)
    eye = target + distance * np.array([math.cos(p) * -math.sin(y), math.cos(p) * -math.cos(y),
                                        math.sin(p)])
    f = (target - eye) / np.linalg.norm(target - eye)
    r = np.cross(f, [0, 0, 1.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    d = np.asarray(points, float) - eye
    x, yy, w = d @ r, d @ u, d @ f
    t = math.tan(math.radians(fov) / 2)
    W, H = size
    return np.column_stack([(x / (w * t * W / H) + 1) / 2 * W, (1 - yy / (w * t)) / 2 * H])


CAM = dict(pitch=30.0, yaw=-45.0, fov=45.0, target=(0.0, 0.0, 0.0), distance=4.0)


def dark_near(gray, pt, radius=1, level=110):
    x, y = int(pt[0]), int(pt[1])
    win = gray[max(0, y - radius):y + radius + 1, max(0, x - radius):x + radius + 1]
    return win.size > 0 and win.min() < level


def seg_dist(p, a, b):
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0, 1)
    return np.linalg.norm(p - (a + t * ab))


def test_camera_projection_matches_independent_pinhole(box):
    view = Camera(**CAM).resolve(box.vertices, SIZE)
    ours = view.to_pixels(box.vertices)
    ref = pinhole(box.vertices, size=SIZE, **CAM)
    assert np.allclose(ours, ref, atol=1e-9)


def test_lines_cube_draws_visible_edges_only(box):
    img = render(box, Camera(**CAM), style="lines", size=SIZE)
    gray = np.asarray(img.convert("L"))
    corners = np.array([[sx, sy, sz] for sx in (-.5, .5) for sy in (-.5, .5) for sz in (-.5, .5)])
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.sum(corners[i] != corners[j]) == 1]
    assert len(edges) == 12
    px = pinhole(corners, size=SIZE, **CAM)
    far = np.array([-.5, .5, -.5])  # the corner facing away from a camera at front-right-top
    hidden = [e for e in edges if any(np.allclose(corners[k], far) for k in e)]
    visible = [e for e in edges if e not in hidden]
    assert len(hidden) == 3 and len(visible) == 9
    for i, j in visible:
        for t in np.linspace(0.1, 0.9, 17):
            assert dark_near(gray, px[i] + t * (px[j] - px[i])), (corners[i], corners[j], t)
    checked = 0
    for i, j in hidden:
        for t in np.linspace(0.1, 0.9, 17):
            p = px[i] + t * (px[j] - px[i])
            if min(seg_dist(p, px[a], px[b]) for a, b in visible) < 4:
                continue  # projects onto a visible edge: nothing to tell apart
            checked += 1
            assert gray[int(p[1]) - 1:int(p[1]) + 2, int(p[0]) - 1:int(p[0]) + 2].min() > 200
    assert checked > 20
    # nothing is drawn far away from the cube
    assert gray[:10].min() == 255 and gray[-10:].min() == 255


def test_lines_hidden_by_another_object():
    front = trimesh.creation.box((3.0, 0.5, 2.0))
    front.apply_translation([0, 0, 1.0])
    back = trimesh.creation.box((1.0, 1.0, 4.0))
    back.apply_translation([0, 3.0, 2.0])
    scene = trimesh.Scene([front, back])
    cam = Camera(pitch=10, yaw=0, projection="orthographic")
    img = render(scene, cam, style="lines", size=SIZE)
    gray = np.asarray(img.convert("L"))
    view = cam.resolve(np.vstack([front.vertices, back.vertices]), SIZE)
    # the back box's front-left vertical edge (x=-0.5, y=2.5): hidden below z~1.6, seen above
    for z in (0.4, 0.8, 1.2):
        p = view.to_pixels([[-0.5, 2.5, z]])[0]
        assert gray[int(p[1]) - 1:int(p[1]) + 2, int(p[0]) - 1:int(p[0]) + 2].min() > 200, z
    for z in (2.6, 3.0, 3.5):
        assert dark_near(gray, view.to_pixels([[-0.5, 2.5, z]])[0]), z


def test_cylinder_silhouettes_without_facet_creases():
    cyl = trimesh.creation.cylinder(radius=1.0, height=3.0, sections=64)
    cam = Camera(pitch=0.0, yaw=0.0, projection="orthographic")
    gray = np.asarray(render(cyl, cam, style="lines", size=SIZE).convert("L"))
    view = cam.resolve(cyl.vertices, SIZE)
    left, right = view.to_pixels([[-1, 0, 0], [1, 0, 0]])
    assert dark_near(gray, left, 2) and dark_near(gray, right, 2)
    mid = view.to_pixels([[0, -1, 0]])[0]
    row = gray[int(mid[1]), int(left[0]) + 4:int(right[0]) - 4]
    assert row.min() > 200  # no lines across the smooth side


def test_shaded_box_has_three_face_intensities(box):
    img = render(box, Camera(**CAM), style="shaded", size=SIZE)
    arr = np.asarray(img).astype(int)
    centres = {"top": [0, 0, .5], "front": [0, -.5, 0], "right": [.5, 0, 0]}
    px = pinhole(np.array(list(centres.values())), size=SIZE, **CAM)
    values = []
    for p in px:
        x, y = int(p[0]), int(p[1])
        patch = arr[y - 3:y + 4, x - 3:x + 4]
        assert np.ptp(patch.reshape(-1, 3), axis=0).max() == 0  # flat shading: uniform face
        values.append(patch[3, 3].mean())
    assert min(abs(a - b) for i, a in enumerate(values) for b in values[i + 1:]) > 15
    assert values[0] == max(values)  # light comes from above
    assert (arr[0, 0] == 255).all()  # background


def test_face_colours_are_used(box):
    colours = np.tile([200, 200, 200, 255], (12, 1))
    top = box.face_normals[:, 2] > 0.9
    colours[top] = [220, 30, 30, 255]
    box.visual.face_colors = colours
    arr = np.asarray(render(box, Camera(**CAM), size=SIZE)).astype(int)
    x, y = pinhole([[0, 0, .5]], size=SIZE, **CAM)[0].astype(int)
    r, g, b = arr[y, x]
    assert r > g + 80 and r > b + 80
    x, y = pinhole([[.5, 0, 0]], size=SIZE, **CAM)[0].astype(int)
    r, g, b = arr[y, x]
    assert abs(r - g) < 3 and abs(g - b) < 3


def test_default_camera_frames_and_centres_the_model(building):
    size = (300, 200)
    cam = Camera()
    px = cam.resolve(building.vertices, size).to_pixels(building.vertices)
    lo, hi = px.min(axis=0), px.max(axis=0)
    margin = cam.margin * np.array(size)
    assert (lo >= margin - 1e-6).all() and (hi <= np.array(size) - margin + 1e-6).all()
    assert np.isclose(lo - margin, 0, atol=0.5).any() or np.isclose(hi, np.array(size) - margin,
                                                                       atol=0.5).any()
    assert np.allclose((lo + hi) / 2, np.array(size) / 2, atol=1.0)
    img = render(building, size=size)
    assert img.size == size


def test_y_up_model_renders_like_z_up(building):
    z_to_y = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]])
    rotated = building.copy()
    rotated.apply_transform(z_to_y)
    a = np.asarray(render(building, size=(128, 128))).astype(int)
    b = np.asarray(render(rotated, Camera(up=(0, 1, 0)), size=(128, 128))).astype(int)
    assert np.abs(a - b).mean() < 0.5


def test_render_accepts_scene_with_transforms(box):
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="A.0", transform=trimesh.transformations.translation_matrix(
        [3.0, 0, 0]))
    cam = Camera(pitch=30, yaw=-45, target=(0, 0, 0), distance=8)
    arr = np.asarray(render(scene, cam, size=SIZE).convert("L"))
    view = cam.resolve(np.zeros((1, 3)), SIZE)
    x, y = view.to_pixels([[3.0, 0, 0.5]])[0].astype(int)
    assert arr[y, x] < 250
    x, y = view.to_pixels([[0.0, 0, 0.5]])[0].astype(int)
    assert arr[y, x] == 255  # nothing at the origin


def test_rasterizer_has_no_cracks_between_triangles(building):
    geom = prepare(building)
    view = Camera(pitch=0, yaw=0, projection="orthographic").resolve(geom.vertices, (200, 200))
    raster = rasterize(geom, view)
    # The front wall (x 0..8, z 0..9 at y=0) is split into many triangles around the window
    # recesses; every pixel inside its projected rectangle must be covered.
    (x0, y1), (x1, y0) = view.to_pixels([[0, 0, 0], [8, 0, 9]])
    inner = raster.face[int(y0) + 1:int(y1) - 1, int(x0) + 1:int(x1) - 1]
    assert inner.size > 5000 and (inner >= 0).all()
    assert len(np.unique(inner)) > 50


def test_same_inputs_same_picture_and_sketchy_seeds(building):
    a = render(building, style="shaded+lines", size=(160, 160))
    b = render(building, style="shaded+lines", size=(160, 160))
    assert a.tobytes() == b.tobytes()
    s1 = render(building, style="lines", size=(160, 160), line_style=LineStyle.sketch(seed=1))
    s1b = render(building, style="lines", size=(160, 160), line_style=LineStyle.sketch(seed=1))
    s2 = render(building, style="lines", size=(160, 160), line_style=LineStyle.sketch(seed=2))
    plain = render(building, style="lines", size=(160, 160))
    assert s1.tobytes() == s1b.tobytes()
    assert s1.tobytes() != s2.tobytes()
    assert s1.tobytes() != plain.tobytes()


def test_transparent_background(box):
    img = render(box, style="shaded+lines", size=(64, 64), background=None)
    assert img.mode == "RGBA"
    alpha = np.asarray(img)[..., 3]
    assert alpha[0, 0] == 0 and alpha[32, 32] == 255


def test_line_options_change_what_is_drawn(building, box):
    full = np.asarray(render(building, style="lines", size=(160, 160)).convert("L")) < 128
    bare = np.asarray(render(building, style="lines", size=(160, 160), line_style=LineStyle(
        creases=False, material_edges=False)).convert("L")) < 128
    assert full.sum() > 1.5 * bare.sum() > 0
    assert (bare & ~full).sum() < 0.05 * bare.sum()  # fewer edges, the same drawing otherwise
    # A cube without creases: the outline (silhouettes) stays, the three inner edges go.
    gray = np.asarray(render(box, Camera(**CAM), style="lines", size=SIZE,
                             line_style=LineStyle(creases=False)).convert("L"))
    near = np.array([.5, -.5, .5])
    inner = [near - np.eye(3)[k] * np.sign(near[k]) for k in range(3)]
    px = pinhole(np.vstack([near[None], inner]), size=SIZE, **CAM)
    for q in px[1:]:
        mid = (px[0] + q) / 2
        assert gray[int(mid[1]) - 1:int(mid[1]) + 2, int(mid[0]) - 1:int(mid[0]) + 2].min() > 200
    top_back = pinhole([[-.5, .5, .5], [.5, .5, .5]], size=SIZE, **CAM)
    assert dark_near(gray, top_back.mean(axis=0))


def test_bad_arguments(box):
    with pytest.raises(ValueError, match="unknown render style"):
        render(box, style="wireframe")
    with pytest.raises(ValueError, match="fov"):
        Camera(fov=0)
    with pytest.raises(ShapeError, match="more than 5 triangles"):
        render(box, max_triangles=5)
    with pytest.raises(ShapeError, match="cannot render"):
        render("not a mesh")


def test_empty_scene_renders_background():
    img = render(trimesh.Scene(), size=(32, 32))
    assert (np.asarray(img) == 255).all()


def test_save_image_is_atomic(tmp_path, box, monkeypatch):
    img = render(box, size=(32, 32))
    out = save_image(img, tmp_path / "a.png")
    assert Image.open(out).size == (32, 32)

    def broken(self, fp, format=None, **kw):
        with open(fp, "wb") as fh:
            fh.write(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(Image.Image, "save", broken)
    with pytest.raises(OSError):
        save_image(img, tmp_path / "b.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png"]
    with pytest.raises(ValueError, match="unknown image format"):
        save_image(img, tmp_path / "c.unknown")


def test_raster_depth_key_matches_the_surface(box):
    geom = prepare(box)
    view = Camera.orthographic(pitch=0, yaw=0).resolve(geom.vertices, (64, 64))
    raster = rasterize(geom, view)
    front_depth = view.depth([[0, -0.5, 0]])[0]
    assert raster.key[32, 32] == pytest.approx(front_depth)
    assert np.isinf(raster.key[0, 0]) and raster.face[0, 0] == -1
    assert box.face_normals[raster.face[32, 32]] @ [0, -1, 0] == pytest.approx(1.0)
    persp = Camera(pitch=0, yaw=0, target=(0, 0, 0), distance=5).resolve(geom.vertices, (64, 64))
    raster = rasterize(geom, persp)
    assert raster.key[32, 32] == pytest.approx(-1 / 4.5)  # -1/depth; front face 4.5 away


def test_rasterizer_chunking_does_not_change_the_result(building):
    geom = prepare(building)
    view = Camera().resolve(geom.vertices, (200, 200))
    reference = rasterize(geom, view).face
    assert (reference >= 0).sum() > 5000
    for chunk in (500, 1 << 12):
        assert np.array_equal(rasterize(geom, view, chunk=chunk).face, reference)
