"""Images: colour curves, file I/O (EXR, PNG/JPEG, Radiance .hdr), encodings and filters."""
