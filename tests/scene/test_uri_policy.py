"""The resource policy for inputs, on crafted files: a buffer or image uri is read only inside
the glTF's own folder (no absolute path, no '..' escape, no symlink or hard link leading
out) unless --allow-outside-files; images nothing uses are never read nor embedded."""
import os

import numpy as np
import pygltflib as gl
import pytest

from patchlight.cli.main import main
from patchlight.imaging.io import encode_png

from gltf_builder import Builder

FLOOR = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
SECRET = b"SECRET-OUTSIDE-THE-FOLDER"


def floor_gltf(folder, buffer_uri="floor.bin", image_uri=None, used=True):
    """folder/floor.gltf: a floor under a sky, its buffer in `buffer_uri` (written beside the
    file when it is a plain name), and an image at `image_uri` that the floor's material uses
    (used) or that no texture names."""
    b = Builder()
    material = None
    if image_uri is not None:
        b.doc.images.append(gl.Image(uri=image_uri, mimeType="image/png"))
        if used:
            b.doc.textures.append(gl.Texture(source=0))
            b.doc.materials.append(gl.Material(pbrMetallicRoughness=gl.PbrMetallicRoughness(
                baseColorTexture=gl.TextureInfo(index=0))))
            material = 0
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    b.scene(b.node(mesh=b.mesh(b.primitive(FLOOR, indices=[0, 2, 1, 0, 3, 2], material=material, TEXCOORD_0=uv))),
            extras={"patchlight": {"sky": {"uniform": [1, 1, 1]}}})
    path = folder / "floor.gltf"
    b.gltf(path, buffer_uri="floor.bin")
    if buffer_uri != "floor.bin":
        path.write_text(path.read_text().replace('"floor.bin"', f'"{buffer_uri}"'))
    return path


def bake(capsys, scene, out, *flags):
    status = main(["bake", str(scene), "-o", str(out), "--resolution", "16", "--quiet", *flags])
    return status, capsys.readouterr().err


@pytest.fixture
def folders(tmp_path):
    """(scene folder, a folder beside it holding a secret file and a picture)."""
    scene, outside = tmp_path / "scene", tmp_path / "outside"
    scene.mkdir()
    outside.mkdir()
    (outside / "secret.txt").write_bytes(SECRET)
    (outside / "picture.png").write_bytes(encode_png(np.full((2, 2, 3), 200, np.uint8)))
    return scene, outside


def test_a_buffer_named_by_an_absolute_path_is_refused_unless_allowed(tmp_path, folders, capsys):
    scene, outside = folders
    path = floor_gltf(scene)
    os.replace(scene / "floor.bin", outside / "floor.bin")
    path.write_text(path.read_text().replace('"floor.bin"', f'"{(outside / "floor.bin").as_posix()}"'))
    status, err = bake(capsys, path, tmp_path / "out")
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert "inside the glTF's folder" in err and "--allow-outside-files" in err
    assert not (tmp_path / "out").exists()
    assert bake(capsys, path, tmp_path / "out", "--allow-outside-files")[0] == 0


@pytest.mark.parametrize("how", ["dotdot", "encoded dotdot", "symlink", "hard link", "symlinked folder"])
def test_a_used_image_leading_out_is_refused(tmp_path, folders, capsys, how):
    scene, outside = folders
    uri = {"dotdot": "../outside/picture.png", "encoded dotdot": "%2E%2E/outside/picture.png",
           "symlink": "picture.png", "hard link": "picture.png", "symlinked folder": "assets/picture.png"}[how]
    if how == "symlink":
        (scene / "picture.png").symlink_to(outside / "picture.png")
    elif how == "hard link":
        os.link(outside / "picture.png", scene / "picture.png")
    elif how == "symlinked folder":
        (scene / "assets").symlink_to(outside)
    status, err = bake(capsys, floor_gltf(scene, image_uri=uri), tmp_path / "out")
    assert status == 2 and "inside the glTF's folder" in err and len(err.strip().splitlines()) == 1, err
    assert bake(capsys, floor_gltf(scene, image_uri=uri), tmp_path / "out", "--allow-outside-files")[0] == 0


@pytest.mark.parametrize("uri", ["/etc/os-release", "../outside/secret.txt", "inside.png"])
def test_an_image_nothing_uses_is_neither_read_nor_embedded(tmp_path, folders, capsys, uri):
    """The audit's crafted file: unused images naming /etc/os-release or a file outside the
    folder put their bytes into scene.glb. Now nothing of them reaches it (an unused image
    inside the folder is not embedded either)."""
    scene, _ = folders
    (scene / "inside.png").write_bytes(encode_png(np.full((2, 2, 3), 7, np.uint8)))
    status, err = bake(capsys, floor_gltf(scene, image_uri=uri, used=False), tmp_path / "out")
    assert status == 0, err
    glb = (tmp_path / "out" / "scene.glb").read_bytes()
    assert SECRET not in glb and b"VERSION_ID" not in glb
    assert (scene / "inside.png").read_bytes() not in glb


def test_a_used_image_inside_the_folder_is_embedded(tmp_path, folders, capsys):
    scene, _ = folders
    picture = encode_png(np.full((2, 2, 3), 9, np.uint8))
    (scene / "sub").mkdir()
    (scene / "sub" / "inside.png").write_bytes(picture)
    status, err = bake(capsys, floor_gltf(scene, image_uri="sub/inside.png"), tmp_path / "out")
    assert status == 0, err
    assert picture in (tmp_path / "out" / "scene.glb").read_bytes()
