"""The viewport draw handler and offscreen scene renders."""
