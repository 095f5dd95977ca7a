"""The viewport draw handler and offscreen scene renders (:mod:`.draw`), drawing through
the drawers each capability registers (:mod:`.registry`); geometry no drawer shades is
drawn as an occluder (:mod:`.occluders`)."""
