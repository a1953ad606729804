"""Design-rule checks on the exported files (trimesh, manifold3d); they report, never raise."""
