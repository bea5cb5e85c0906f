-- POST batches of fixes with timestamps unique per request (and per wrk thread).
-- wrk -s ingest.lua URL -- <batch> <first_unix_second> <api_key>[,<api_key>...] [<etag>,...]
-- Fix k of this thread is at first_unix_second + thread_offset + k/100 s (ISO 8601, +00:00).
-- Several keys (comma-separated): wrk thread i posts with key i (mod their number), so with one
-- connection per thread (-t N -c N) each connection is its own boat. ETags (one per key): sent
-- in X-Commands-ETag with Prefer: return=minimal, as the edge client does (one exchange per
-- period, docs/api.md).
local dir = debug.getinfo(1, "S").source:match("^@(.*/)") or "./"
dofile(dir .. "common.lua")

local batch, first, key, sent, offset

function init(args)
   batch = tonumber(args[1])
   first = tonumber(args[2])
   local keys = {}
   for k in string.gmatch(args[3], "[^,]+") do keys[#keys + 1] = k end
   key = keys[(thread_index or 0) % #keys + 1]
   if args[4] then
      local etags = {}
      for e in string.gmatch(args[4], "[^,]+") do etags[#etags + 1] = e end
      wrk.headers["X-Commands-ETag"] = etags[(thread_index or 0) % #etags + 1]
      wrk.headers["Prefer"] = "return=minimal"  -- a settled exchange is then a bare 204
   end
   sent = 0
   -- a million seconds per thread: no two threads ever share a timestamp
   offset = (thread_index or 0) * 1000000
   wrk.method = "POST"
   wrk.headers["Content-Type"] = "application/json"
   wrk.headers["Authorization"] = "Api-Key " .. key
end

local function iso(k)
   local second = first + offset + math.floor(k / 100)
   return os.date("!%Y-%m-%dT%H:%M:%S", second) .. string.format(".%06d+00:00", (k % 100) * 10000)
end

function request()
   local parts = {}
   for i = 1, batch do
      local k = sent + i - 1
      parts[i] = string.format(
         '{"time":"%s","lat":%.6f,"lon":%.6f,"heading_deg":%.1f,"speed_mps":%.2f,' ..
         '"battery_v":%.2f,"readings":{"water_temp_c":%.2f,"salinity_psu":%.2f}}',
         iso(k), -32.05 + (k % 1000) * 1e-5, 115.74 + (k % 777) * 1e-5, (k * 7) % 360,
         1.5 + (k % 10) * 0.1, 12.6 - (k % 50) * 0.01, 18.0 + (k % 30) * 0.05,
         35.0 + (k % 20) * 0.01)
   end
   sent = sent + batch
   return wrk.format(nil, nil, nil, '{"fixes":[' .. table.concat(parts, ",") .. ']}')
end

function response(status, headers, body)
   local ok
   if wrk.headers["X-Commands-ETag"] then  -- every fix taken, the list unchanged: 204, no body
      ok = status == 204 and (body == nil or body == "")
   else
      ok = status == 200 and string.find(body, '"rejected":%[%]') ~= nil
   end
   count_response(ok, status, body)
end
