"""Building blocks of the Wave Glider bridge (docs/wave-glider.md; issue 11), one job per module.

* ``commands``: the database as the payload machine's command source (one handover at a time,
  results matched in order, timeouts, crash-safe retries);
* ``machine``: the payload machine that tells the source which request it is answering;
* ``fixes``: the C&C's status requests stored as the glider's fixes;
* ``records`` + ``sensor_layouts.toml``: pure decoder of the payload board's UDP records;
* ``sensors``: the UDP subscriber feeding the latest readings; ``sensor_standin``: a stand-in
  for the payload board's data servers (tests, demos);
* ``power``: what a power-down notice runs;
* ``dispatch``: routes the machine's notifications to the above;
* ``sms_link``: the modem thread (SMS in through the SMS service, held replies, SMS out);
* ``process``: the whole bridge, ``manage.py run_wg_bridge`` (threads, housekeeping, stop);
* ``demo``: ``python -m sms.bridge.demo``, the bridge between the two simulators.

Wiring (as ``process.Bridge`` does)::

    readings = LatestReadings()                     # its .state is the status block's source
    source = DatabaseCommandSource(vessel=glider)   # result_timeout_s=, quarantine_s=
    machine = BridgeMachine(PayloadConfig(...), source=source, sensors=readings.state)
    fixes = FixRecorder(vessel=glider, readings=readings.snapshot)
    dispatch = Dispatcher(machine=machine, source=source, fixes=fixes, power_command=argv)
    runner = PayloadRunner(url, machine, on_notification=dispatch)    # its own thread
    subscriber = SensorSubscriber(host, list(RecordTable.load().records.values()), readings)
    # thread: with subscriber: subscriber.run(stop_event)
    # the loop, about once a second: source.expire_overdue(); fixes.flush_if_due();
    #   source.flush_results(); close_old_connections()
    # on stop: runner.stop(); fixes.flush(); source.flush_results()

Nothing is imported here, so ``python -m sms.bridge.sensor_standin`` needs no Django.
"""
