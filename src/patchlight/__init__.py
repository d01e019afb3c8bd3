"""patchlight: baked radiosity lightmaps and the classic real-time lighting models, on the CPU."""
