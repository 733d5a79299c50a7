"""Pictures: body meshes, capsules, pressure images (matplotlib, headless-safe)."""
