"""The web viewer: a three.js page running the GLSL chunks, and its local server."""
