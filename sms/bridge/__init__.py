"""Building blocks of the Wave Glider bridge (DESIGN §7; issue 11), one job per module.

* ``commands``: the database as the payload machine's command source (one handover at a time,
  results matched in order, timeouts, crash-safe retries);
* ``machine``: the payload machine that tells the source which request it is answering;
* ``fixes``: the C&C's status requests stored as the glider's fixes;
* ``records`` + ``sensor_layouts.toml``: pure decoder of the payload board's UDP records;
* ``sensors``: the UDP subscriber feeding the latest readings; ``sensor_standin``: a stand-in
  for the payload board's data servers (tests, demos);
* ``power``: what a power-down notice runs;
* ``dispatch``: routes the machine's notifications to the above.

Nothing is imported here, so ``python -m sms.bridge.sensor_standin`` needs no Django.
"""
