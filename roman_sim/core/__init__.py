"""Infrastructure every layer uses: errors, configuration, registries, seeding, atomic writes,
resource measurement, TUM trajectory files and the offscreen OpenGL context."""
