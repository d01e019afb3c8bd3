"""GLSL chunks of the runtime lighting models: the single source the viewer loads."""
