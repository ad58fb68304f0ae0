"""Flight telemetry against rbenv: read the mission's logs (:mod:`.telemetry`), replay a policy
from logged starts (:mod:`.replay`) and identify a scene's parameters from the logs
(:mod:`.identify`)."""
