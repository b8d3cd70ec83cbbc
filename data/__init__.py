"""Library data shipped inside the wheel as `gfxlab._data` (read via `gfxlab._resources`)."""
