"""A glTF document written by hand with pygltflib, for the scene tests: one buffer, helpers for
accessors, primitives, meshes, nodes and images, saved as .glb or .gltf."""
import base64

import numpy as np
import pygltflib as gl

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125


class Builder:
    """A glTF document under construction: one buffer, helpers for accessors and nodes."""

    def __init__(self):
        self.doc = gl.GLTF2(asset=gl.Asset(version="2.0"))
        self.blob = bytearray()

    def view(self, data: bytes, stride=None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.doc.bufferViews.append(gl.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data),
                                                  byteStride=stride))
        self.blob += data
        return len(self.doc.bufferViews) - 1

    def accessor(self, values, kind=None, component=FLOAT, normalized=False, view=None, offset=0, count=None,
                 bounds=False, stride=None) -> int:
        """An accessor over `values` in a new bufferView (or `view`); bounds: its min and max;
        stride: each element padded to that many bytes."""
        dtype = {FLOAT: "<f4", UBYTE: "<u1", USHORT: "<u2", UINT: "<u4"}[component]
        values = np.asarray(values, dtype)
        width = 1 if values.ndim == 1 else values.shape[1]
        kind = kind or {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[width]
        if view is None:
            data = values.tobytes()
            if stride is not None:
                padded = np.zeros((len(values), stride), np.uint8)
                padded[:, :values[0].nbytes] = values.view(np.uint8).reshape(len(values), -1)
                data = padded.tobytes()
            view = self.view(data, stride)
        accessor = gl.Accessor(bufferView=view, byteOffset=offset, componentType=component, normalized=normalized,
                               count=len(values) if count is None else count, type=kind)
        if bounds:
            accessor.min = np.atleast_2d(values.T).T.min(axis=0).tolist()
            accessor.max = np.atleast_2d(values.T).T.max(axis=0).tolist()
        self.doc.accessors.append(accessor)
        return len(self.doc.accessors) - 1

    def primitive(self, positions, indices=None, mode=4, material=None, **attributes) -> gl.Primitive:
        attrs = {"POSITION": self.accessor(positions)}
        attrs.update({k: v if isinstance(v, int) else self.accessor(v) for k, v in attributes.items()})
        index = None if indices is None else self.accessor(np.asarray(indices).ravel(), component=UINT)
        return gl.Primitive(attributes=gl.Attributes(**attrs), indices=index, mode=mode, material=material)

    def mesh(self, *primitives, name=None) -> int:
        self.doc.meshes.append(gl.Mesh(name=name, primitives=list(primitives)))
        return len(self.doc.meshes) - 1

    def node(self, **fields) -> int:
        self.doc.nodes.append(gl.Node(**fields))
        return len(self.doc.nodes) - 1

    def scene(self, *roots, extras=None):
        self.doc.scenes = [gl.Scene(nodes=list(roots), extras=extras or {})]
        self.doc.scene = 0

    def image(self, png: bytes) -> int:
        self.doc.images.append(gl.Image(bufferView=self.view(png), mimeType="image/png"))
        self.doc.textures.append(gl.Texture(source=len(self.doc.images) - 1))
        return len(self.doc.textures) - 1

    def glb(self, path):
        self.doc.buffers = [gl.Buffer(byteLength=len(self.blob))]
        self.doc.set_binary_blob(bytes(self.blob))
        path.write_bytes(b"".join(self.doc.save_to_bytes()))
        return path

    def gltf(self, path, buffer_uri=None):
        """A .gltf with the buffer in `buffer_uri` (a file written beside it) or a data: URI."""
        if buffer_uri is None:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
        else:
            uri = buffer_uri
            (path.parent / buffer_uri).write_bytes(bytes(self.blob))
        self.doc.buffers = [gl.Buffer(uri=uri, byteLength=len(self.blob))]
        path.write_text(self.doc.gltf_to_json())
        return path
