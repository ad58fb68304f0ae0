"""Flight telemetry against rbenv: replay a policy from logged starts, identify a scene's
parameters from the logs (:mod:`.replay`, :mod:`.identify`)."""
