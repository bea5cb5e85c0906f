-- GET with fixed headers (the no-news poll, or the bare Django view); counts the expected status.
-- wrk -s get.lua URL -- <expected_status> [<api_key> [<if_none_match>]]
local dir = debug.getinfo(1, "S").source:match("^@(.*/)") or "./"
dofile(dir .. "common.lua")

local expected

function init(args)
   expected = tonumber(args[1])
   if args[2] and args[2] ~= "" then
      wrk.headers["Authorization"] = "Api-Key " .. args[2]
   end
   if args[3] and args[3] ~= "" then
      wrk.headers["If-None-Match"] = args[3]
   end
end

function response(status, headers, body)
   count_response(status == expected, status, body)
end
