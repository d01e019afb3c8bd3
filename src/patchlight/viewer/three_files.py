"""The three.js files the viewer page imports, relative to the `three` npm package: the one
list the build step copies into the package (setup.py) and the server serves (server.py).
Plain data, no imports: setup.py reads it before patchlight is installed."""

THREE_FILES = (
    "build/three.module.js",
    "build/three.core.js",
    "examples/jsm/controls/OrbitControls.js",
    "examples/jsm/loaders/GLTFLoader.js",
    "examples/jsm/loaders/HDRLoader.js",
    "examples/jsm/loaders/EXRLoader.js",
    "examples/jsm/libs/fflate.module.js",  # EXRLoader's inflate (MIT, its licence in its header)
    "examples/jsm/utils/BufferGeometryUtils.js",
    "examples/jsm/utils/SkeletonUtils.js",
)
THREE_LICENSE = ("LICENSE", "package.json")  # kept beside the files: the MIT licence and the version
BUNDLED = "three"  # the folder inside patchlight/viewer/ that a built package holds them in
