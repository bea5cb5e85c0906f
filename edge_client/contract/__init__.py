"""The boat–shore contract: the rules the edge client and the server must agree on, kept once.

Kinds and Rover's modes (:mod:`.kinds`), the command catalog's MAVLink kinds, parameters,
ranges and limits (:mod:`.catalog`), the MAV_CMD numbers a mission is built from
(:mod:`.mavcmd`), command status names (:mod:`.status`), the Earth's geometry (:mod:`.geo`),
a fix's wire fields and ranges (:mod:`.fix`), the answer to a batch upload (:mod:`.batch`)
and the backoff every retry loop uses (:mod:`.backoff`).
It lives inside ``edge_client`` so that a Pi which copies that folder alone still has it; the
server imports it from here. Pure and stdlib-only: no Django, no pymavlink, no I/O
(``tests/fleet/test_layers.py`` checks), so either side may import it anywhere.
"""
