"""Seeded fuzzing of the command line: mutated inputs, one property, failure signatures.

Inputs are made from a small valid seed (a textured floor and wall with a point light, as
.glb and .gltf, its bake, a light volume and a ground map of it) by the mutators below:
glTF JSON values replaced, removed or nested; GLB bytes flipped, cut, spliced and their
length fields rewritten; bake, volume and ground-map files cut, flipped, emptied, removed or
given non-finite values; plus the hostile cases found by hand (deep JSON, huge integers and
counts, long uris, a FIFO, an image that decodes to gigabytes).

The property every run must have: exit status 0 or 2, no traceback, at most three lines on
stderr, after a failure nothing left in the output (neither the output nor a staging folder),
and no run over 60 s or 2 GiB. A broken run gets a signature (what broke and where, without
the case's numbers), so thousands of cases reduce to the few distinct defects.

Used by tests/fuzz/test_fuzz.py (a bounded run) and bench/fuzz.py (thousands of cases).
"""
from __future__ import annotations

import copy
import io
import json
import os
import random
import re
import shutil
import struct
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
TIME_LIMIT_S, MEMORY_LIMIT_MIB, MAX_STDERR_LINES = 60.0, 2048.0, 3

# Small settings, so a case that gets through runs in a second or two.
BAKE = ["--resolution", "16", "--gather", "stratified", "--rays", "16", "--passes", "2", "--quiet"]
VOLUME = ["--dims", "3,2,3", "--rays", "16", "--quiet"]
GROUND = ["--size", "16", "--quiet"]
RENDER = ["--size", "24x16", "--exposure", "1"]

INTERESTING = [None, True, -1, 0, 1, 3, 255, 2**31, 2**32 + 1, 2**40, 2**63, -2**63, 1e308, -1e308, 1e-320,
               float("inf"), float("nan"), "", "0", "x" * 300, "data:,", "data:;base64,@@", "../" * 8 + "etc/hostname",
               [], [0], [1e30] * 16, {}, {"a": 1}]


@dataclass
class Case:
    """One command over files made in `folder`; `output`: where it writes (checked after a failure)."""

    kind: str
    argv: list[str]
    output: Path | None
    note: str = ""


@dataclass
class Outcome:
    case: Case
    status: int | None
    signal: int | None
    seconds: float
    peak_mib: float
    killed: str | None
    stderr: str
    leftovers: list[str] = field(default_factory=list)

    @property
    def signature(self) -> str | None:
        """None when the run kept the property, else what broke, in the case's own words."""
        command = self.case.argv[0]
        if self.killed:
            return f"{command}: over the {self.killed} limit"
        if self.signal is not None:
            return f"{command}: killed by signal {self.signal}"
        if "Traceback (most recent call last)" in self.stderr:
            return f"{command}: traceback {_traceback_signature(self.stderr)}"
        if self.status not in (0, 2):
            return f"{command}: exit status {self.status}"
        lines = self.stderr.strip().splitlines()
        if len(lines) > MAX_STDERR_LINES:
            return f"{command}: {len(lines)} lines on stderr ({_shape(lines[-1])})"
        if self.status == 2 and self.leftovers:
            return f"{command}: failed but left {', '.join(sorted({_shape(n) for n in self.leftovers}))}"
        return None


def _shape(text: str) -> str:
    """A message with its numbers, quoted values and paths taken out, so alike failures match."""
    text = re.sub(r"(/[^\s:'\"]*)+", "PATH", text)
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "Q", text)
    return re.sub(r"-?\d[\d.e+-]*", "N", text)[:120]


def _traceback_signature(stderr: str) -> str:
    """The exception's type and the innermost patchlight frame (file:function)."""
    frames = re.findall(r'File "([^"]+)", line \d+, in (\S+)', stderr)
    ours = [(f, fn) for f, fn in frames if "/patchlight/" in f]
    where = f"{ours[-1][0].split('/patchlight/')[-1]}:{ours[-1][1]}" if ours else "outside patchlight"
    last = stderr.strip().splitlines()[-1]
    return f"{last.split(':')[0]} at {where}"


# --------------------------------------------------------------------------- seeds

class Seeds:
    """The valid inputs every case starts from, made once in `folder`."""

    def __init__(self, folder: Path, runner: "Runner"):
        self.folder = folder
        self.glb, self.gltf = folder / "seed.glb", folder / "seed.gltf"
        self.bake, self.volume, self.ground = folder / "bake", folder / "volume", folder / "ground"
        if not self.bake.is_dir():
            self._make(runner)

    def _make(self, runner: "Runner") -> None:
        sys.path.insert(0, str(HERE.parent / "scene"))
        from gltf_builder import Builder
        import pygltflib as gl
        from PIL import Image

        self.folder.mkdir(parents=True, exist_ok=True)
        b = Builder()
        positions = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 2], [0, 0, 2], [0, 0, 0], [0, 1, 0], [2, 1, 0], [2, 0, 0]], np.float32)
        normals = np.array([[0, 1, 0]] * 4 + [[0, 0, 1]] * 4, np.float32)
        uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]] * 2, np.float32)
        png = io.BytesIO()
        Image.new("RGB", (4, 4), (200, 150, 100)).save(png, "PNG")
        texture = b.image(png.getvalue())
        b.doc.materials.append(gl.Material(pbrMetallicRoughness=gl.PbrMetallicRoughness(
            baseColorTexture=gl.TextureInfo(index=texture))))
        mesh = b.mesh(b.primitive(positions, np.array([0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7]), material=0,
                                  NORMAL=normals, TEXCOORD_0=uv))
        b.doc.extensionsUsed = ["KHR_lights_punctual"]
        b.doc.extensions = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 5.0}]}}
        light = b.node(translation=[1.0, 0.6, 1.0], extensions={"KHR_lights_punctual": {"light": 0}})
        b.scene(b.node(mesh=mesh), light)
        b.glb(self.glb)
        b.gltf(self.gltf)
        for argv in (["bake", str(self.glb), "-o", str(self.bake), *BAKE],
                     ["volume", str(self.bake), "-o", str(self.volume), *VOLUME],
                     ["groundmap", str(self.bake), "-o", str(self.ground), *GROUND]):
            outcome = runner.run(Case("seed", argv, None))
            if outcome.status != 0:
                raise RuntimeError(f"seed {argv[0]} failed ({outcome.signature or outcome.status}): {outcome.stderr}")


# --------------------------------------------------------------------------- mutators

def _paths(node, prefix=()):
    """Every (path, value) in a JSON tree."""
    yield prefix, node
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _paths(value, prefix + (key,))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from _paths(value, prefix + (i,))


def _interesting(rng: random.Random, old):
    if isinstance(old, (int, float)) and not isinstance(old, bool) and rng.random() < 0.3:
        return rng.choice([old + 1, old - 1, -old, old * 2**20, old * 1e30])
    return copy.deepcopy(rng.choice(INTERESTING))


def mutate_json(document: dict, rng: random.Random) -> dict:
    """1-3 mutations: a value replaced by an interesting one, a key removed, a list emptied
    or repeated, or a value nested deep."""
    doc = copy.deepcopy(document)
    for _ in range(rng.randint(1, 3)):
        paths = [p for p, _ in _paths(doc) if p]
        path = rng.choice(paths)
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        key, old = path[-1], parent[path[-1]]
        action = rng.random()
        if action < 0.6:
            parent[key] = _interesting(rng, old)
        elif action < 0.75 and isinstance(parent, dict):
            del parent[key]
        elif action < 0.85 and isinstance(old, list):
            parent[key] = old * rng.choice([0, 2, 50])
        elif action < 0.92:
            parent[key] = [old] if rng.random() < 0.5 else {"k": old}
        else:
            parent[key] = deep(rng.choice([50, 990, 5000])) if rng.random() < 0.7 else digits(5000)
    return doc


def deep(levels: int) -> str:
    """A stand-in that `dumps` writes as a list nested `levels` deep (json.dumps cannot)."""
    return f"@@deep:{levels}@@"


def digits(count: int) -> str:
    """A stand-in that `dumps` writes as an integer of `count` digits (json.dumps cannot)."""
    return f"@@digits:{count}@@"


def dumps(document) -> str:
    """JSON text of a document, NaN and Infinity tokens allowed, stand-ins expanded."""
    def expand(match):
        n = int(match[2])
        return "[" * n + "0" + "]" * n if match[1] == "deep" else "9" * n
    return re.sub(r'"@@(deep|digits):(\d+)@@"', expand, json.dumps(document))


def mutate_bytes(data: bytes, rng: random.Random, fields: tuple[int, ...] = ()) -> bytes:
    """Bits flipped, a cut, a splice, or a 32-bit field (e.g. a GLB length) rewritten."""
    data = bytearray(data)
    action = rng.random()
    if action < 0.35:
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    elif action < 0.55:
        del data[rng.randrange(len(data)):]
    elif action < 0.7:
        at = rng.randrange(len(data))
        data[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 64)))
    elif fields:
        at = rng.choice(fields)
        value = rng.choice([0, 1, 3, len(data), len(data) + 1, 2**31, 2**32 - 1])
        data[at:at + 4] = struct.pack("<I", value)
    else:
        at = rng.randrange(len(data))
        del data[at:at + rng.randint(1, 16)]
    return bytes(data)


def glb_parts(data: bytes) -> tuple[dict, bytes]:
    """The JSON document and the BIN chunk of a valid GLB."""
    json_length = struct.unpack_from("<I", data, 12)[0]
    document = json.loads(data[20:20 + json_length])
    rest = data[20 + json_length:]
    return document, rest[8:8 + struct.unpack_from("<I", rest, 0)[0]] if rest else b""


def glb_bytes(document, blob: bytes) -> bytes:
    """A GLB container of a JSON document (any JSON value, NaN allowed) and a BIN chunk."""
    text = dumps(document).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
    return b"glTF" + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def damage_file(path: Path, rng: random.Random) -> str:
    """Damage one file in place; returns what was done."""
    data = path.read_bytes()
    action = rng.random()
    if action < 0.1:
        path.unlink()
        return "removed"
    if action < 0.15:
        path.write_bytes(b"")
        return "emptied"
    if path.suffix == ".json" and action < 0.6:
        path.write_text(dumps(mutate_json(json.loads(data), rng)))
        return "json mutated"
    if path.suffix in (".exr", ".bin") and action < 0.45:
        return _non_finite(path, rng)
    path.write_bytes(mutate_bytes(data, rng))
    return "bytes mutated"


def _non_finite(path: Path, rng: random.Random) -> str:
    value = rng.choice([np.nan, np.inf, -np.inf, 3e38, -1.0])
    if path.suffix == ".bin":
        data = bytearray(path.read_bytes())
        at = rng.randrange(len(data) // 4) * 4
        data[at:at + 4] = np.float32(value).tobytes()
        path.write_bytes(bytes(data))
    else:
        import OpenEXR

        with OpenEXR.File(str(path)) as exr:
            header = dict(exr.header())
            channels = {name: np.array(c.pixels) for name, c in exr.channels().items()}
        key = "RGBA" if "RGBA" in channels else "RGB"  # a bake's lightmap.exr carries its validity as A
        rgb = channels[key]
        rgb.reshape(-1)[rng.randrange(rgb.size)] = value
        OpenEXR.File(header, {key: rgb}).write(str(path))
    return f"a {value} value"


# --------------------------------------------------------------------------- cases

class Cases:
    """Seeded cases over the seeds: case i of seed s is always the same."""

    def __init__(self, seeds: Seeds, work: Path, seed: int):
        self.seeds, self.work, self.rng = seeds, work, random.Random(seed)
        self.glb_document, self.glb_blob = glb_parts(seeds.glb.read_bytes())
        self.gltf_document = json.loads(seeds.gltf.read_text())

    def make(self, index: int) -> Case:
        folder = self.work / f"case{index}"
        folder.mkdir(parents=True)
        kind = self.rng.choice(["gltf-json", "gltf-json", "glb-json", "glb-bytes", "glb-bytes",
                                "bake-dir", "bake-dir", "volume", "ground"])
        return getattr(self, kind.replace("-", "_"))(folder)

    def _scene_command(self, scene: Path, folder: Path) -> Case:
        command = self.rng.choice(["bake", "bake", "bake", "render", "volume", "vertexbake"])
        out = folder / "out"
        if command == "bake":
            argv = ["bake", str(scene), "-o", str(out), *BAKE]
        elif command == "render":
            out = folder / "out.png"
            argv = ["render", str(scene), "-o", str(out), *RENDER, "--model", self.rng.choice(["lambert", "phong"])]
        elif command == "volume":
            argv = ["volume", str(scene), "-o", str(out), *VOLUME]
        else:
            out = folder / "out.glb"
            argv = ["vertexbake", str(scene), "-o", str(out), "--quiet"]
        return Case(command, argv, out)

    def gltf_json(self, folder: Path) -> Case:
        scene = folder / "scene.gltf"
        scene.write_text(dumps(mutate_json(self.gltf_document, self.rng)))
        return self._scene_command(scene, folder)

    def glb_json(self, folder: Path) -> Case:
        scene = folder / "scene.glb"
        scene.write_bytes(glb_bytes(mutate_json(self.glb_document, self.rng), self.glb_blob))
        return self._scene_command(scene, folder)

    def glb_bytes(self, folder: Path) -> Case:
        scene = folder / "scene.glb"
        data = self.seeds.glb.read_bytes()
        json_end = 20 + struct.unpack_from("<I", data, 12)[0]
        scene.write_bytes(mutate_bytes(data, self.rng, fields=(8, 12, json_end)))
        return self._scene_command(scene, folder)

    def bake_dir(self, folder: Path) -> Case:
        bake = folder / "bake"
        shutil.copytree(self.seeds.bake, bake)
        damaged = self.rng.choice(["lightmap.exr", "lightmap.exr", "scene.glb", "bake.json"])
        note = f"{damaged}: {damage_file(bake / damaged, self.rng)}"
        command = self.rng.choice(["render", "volume", "vertexbake", "groundmap"])
        out = folder / "out"
        if command == "render":
            out = folder / "out.png"
            argv = ["render", str(bake), "-o", str(out), *RENDER, "--model", "lightmap"]
        elif command == "volume":
            argv = ["volume", str(bake), "-o", str(out), *VOLUME]
        elif command == "vertexbake":
            out = folder / "out.glb"
            argv = ["vertexbake", str(bake), "-o", str(out), "--quiet"]
        else:
            argv = ["groundmap", str(bake), "-o", str(out), *GROUND]
        return Case(command, argv, out, note)

    def volume(self, folder: Path) -> Case:
        volume = folder / "volume"
        shutil.copytree(self.seeds.volume, volume)
        damaged = self.rng.choice(["light_volume.json", "light_volume.bin"])
        note = f"{damaged}: {damage_file(volume / damaged, self.rng)}"
        out = folder / "out.png"
        argv = ["render", str(self.seeds.bake), "-o", str(out), *RENDER, "--model", "ambient-cube",
                "--volume", str(volume)]
        return Case("render", argv, out, note)

    def ground(self, folder: Path) -> Case:
        ground = folder / "ground"
        shutil.copytree(self.seeds.ground, ground)
        files = sorted(p.name for p in ground.iterdir() if p.suffix in (".json", ".png", ".dds") and p.name != "bake.json")
        damaged = self.rng.choice(files + ["groundmap.json"] * 2)
        note = f"{damaged}: {damage_file(ground / damaged, self.rng)}"
        out = folder / "out.png"
        argv = ["render", str(ground), "-o", str(out), *RENDER, "--model", "hemisphere-radiosity"]
        return Case("render", argv, out, note)


def hostile_cases(seeds: Seeds, work: Path) -> list[Case]:
    """The hostile inputs found by hand, each once."""
    cases = []
    document, blob = glb_parts(seeds.glb.read_bytes())

    def scene_case(name: str, doc, data: bytes = blob, command: str = "bake") -> None:
        folder = work / f"hostile-{len(cases)}"
        folder.mkdir(parents=True)
        scene = folder / "scene.glb"
        scene.write_bytes(doc if isinstance(doc, bytes) else glb_bytes(doc, data))
        out = folder / "out"
        cases.append(Case(command, [command, str(scene), "-o", str(out), *(BAKE if command == "bake" else VOLUME)],
                          out, name))

    def edited(edit) -> dict:
        """A copy of the document after `edit`; fields set to None are removed."""
        doc = copy.deepcopy(document)
        edit(doc)
        for _, value in _paths(doc):
            if isinstance(value, dict):
                for key in [k for k, v in value.items() if v is None]:
                    del value[key]
        return doc

    scene_case("JSON nested 990 deep", edited(lambda d: d.update(extras={"deep": deep(990)})))
    scene_case("a 5,000-digit integer", edited(lambda d: d["accessors"][0].update(count=digits(5000))))
    scene_case('"scene": "0"', edited(lambda d: d.update(scene="0")))
    scene_case('"scene": [0]', edited(lambda d: d.update(scene=[0])))
    scene_case("a 300-character uri", edited(lambda d: d["images"][0].update(uri="a" * 300 + ".png", bufferView=None)))
    scene_case("accessor count a string", edited(lambda d: d["accessors"][0].update(count="3")))
    scene_case("extensionsUsed holds a number", edited(lambda d: d.update(extensionsUsed=[5])))
    scene_case("a light of infinite intensity", edited(
        lambda d: d["extensions"]["KHR_lights_punctual"]["lights"][0].update(intensity=float("inf"))))
    for power in (28, 33, 40):
        scene_case(f"accessor count 2^{power}, no bufferView", edited(
            lambda d: d["accessors"][0].update(count=2**power, bufferView=None, min=None, max=None)))
    for power in (28, 33):
        scene_case(f"index accessor count 2^{power}, no bufferView",
                   edited(lambda d: d["accessors"][-1].update(count=2**power, bufferView=None)))
    scene_case("buffer byteLength 2^40", edited(lambda d: d["buffers"][0].update(byteLength=2**40)))
    from PIL import Image

    big = io.BytesIO()
    Image.new("L", (12000, 12000)).save(big, "PNG", optimize=False)
    huge = glb_bytes(edited(lambda d: d["bufferViews"].append({"buffer": 0, "byteOffset": len(blob),
                                                                "byteLength": len(big.getvalue())})
                            or d["images"][0].update(bufferView=len(d["bufferViews"]) - 1)),
                     blob + big.getvalue())
    huge_doc, _ = glb_parts(huge)
    huge_doc["buffers"][0]["byteLength"] = len(blob) + len(big.getvalue())
    scene_case("a 12,000 x 12,000 PNG texture", glb_bytes(huge_doc, blob + big.getvalue()))
    fifo_folder = work / "hostile-fifo"
    fifo_folder.mkdir(parents=True)
    os.mkfifo(fifo_folder / "x.glb")
    cases.append(Case("bake", ["bake", str(fifo_folder / "x.glb"), "-o", str(fifo_folder / "out"), *BAKE],
                      fifo_folder / "out", "a FIFO named x.glb"))
    cases.append(Case("bake", ["bake", "/dev/zero", "-o", str(work / "hostile-dev-out"), *BAKE],
                      work / "hostile-dev-out", "a device"))
    return cases


# --------------------------------------------------------------------------- running

class Runner:
    """A fork server (forkserver.py) that runs each case under the time and memory limits."""

    def __init__(self):
        self.process = subprocess.Popen([sys.executable, str(HERE / "forkserver.py"), str(TIME_LIMIT_S),
                                         str(MEMORY_LIMIT_MIB)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                        text=True)

    def run(self, case: Case) -> Outcome:
        folder = (case.output.parent if case.output else Path(case.argv[1]).parent)
        stdout, stderr = folder / ".fuzz-stdout", folder / ".fuzz-stderr"
        self.process.stdin.write(json.dumps({"argv": case.argv, "cwd": str(folder), "out": str(stdout),
                                             "err": str(stderr)}) + "\n")
        self.process.stdin.flush()
        answer = json.loads(self.process.stdout.readline())
        text = stderr.read_text(errors="replace")
        stdout.unlink()
        stderr.unlink()
        leftovers = []
        if case.output is not None:
            if case.output.exists() and (case.output.is_file() or any(case.output.iterdir())):
                leftovers.append(case.output.name)
            leftovers += [p.name for p in case.output.parent.glob(f".{case.output.stem}*")]
        return Outcome(case, answer["status"], answer["signal"], answer["seconds"], answer["peak_mib"],
                       answer["killed"], text, leftovers)

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait(timeout=30)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
