"""Off the simulator: vehicle links over the wire and the real-time AMP runner.

:mod:`cptbt.bridge.backseat` is the JSON-lines protocol, :mod:`cptbt.bridge.backseat_link` its
UDP adapter, :mod:`cptbt.bridge.mavlink_link` the MAVLink adapter, :mod:`cptbt.bridge.serve` the
real-time loop around :class:`cptbt.session.AmpSession`. Nothing here imports the simulator: the
front-seat doubles that fly it live in the application layer (:mod:`cptbt.batch.frontseat`).
"""

from cptbt.bridge.base import LinkURI, LinkURIError, WireLink, open_link, parse_uri

__all__ = ["LinkURI", "LinkURIError", "WireLink", "open_link", "parse_uri"]
