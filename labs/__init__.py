"""The labs, shipped inside the wheel as `gfxlab._labs` (`python -m gfxlab labs --copy DIR`)."""
