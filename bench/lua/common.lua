-- Shared by the bench scripts: per-thread status counts and a one-line JSON summary that
-- bench/server/wrk.py parses ("BENCH_JSON {...}"). Loaded with dofile from each script.
local threads = {}

function setup(thread)
   thread:set("thread_index", #threads)
   table.insert(threads, thread)
end

ok_count = 0
bad_count = 0
first_bad = ""

function count_response(good, status, body)
   if good then
      ok_count = ok_count + 1
   else
      bad_count = bad_count + 1
      if first_bad == "" then
         first_bad = tostring(status) .. " " .. string.sub(body or "", 1, 200)
      end
   end
end

function done(summary, latency, requests)
   local ok, bad, sample = 0, 0, ""
   for _, thread in ipairs(threads) do
      ok = ok + (thread:get("ok_count") or 0)
      bad = bad + (thread:get("bad_count") or 0)
      local first = thread:get("first_bad") or ""
      if sample == "" then sample = first end
   end
   local e = summary.errors
   sample = string.gsub(sample, '[%c"\\]', " ")
   io.write(string.format(
      'BENCH_JSON {"requests": %d, "duration_us": %d, "bytes": %d, "ok": %d, "bad": %d, ' ..
      '"first_bad": "%s", "connect_errors": %d, "read_errors": %d, "write_errors": %d, ' ..
      '"status_errors": %d, "timeouts": %d, "lat_p50_us": %d, "lat_p90_us": %d, ' ..
      '"lat_p99_us": %d, "lat_max_us": %d, "lat_mean_us": %.1f}\n',
      summary.requests, summary.duration, summary.bytes, ok, bad, sample,
      e.connect, e.read, e.write, e.status, e.timeout,
      latency:percentile(50), latency:percentile(90), latency:percentile(99),
      latency.max, latency.mean))
end
