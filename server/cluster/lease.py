"""Leases in Redis: each source is followed by exactly one worker, and taken over when it dies.

A worker runs ``tick`` a few times per lease time. One Lua script (atomic
in Redis, on Redis's clock) registers the worker as live, renews the leases
it still holds, and takes free ones up to its fair share (the sources
divided by the live workers, rounded up), so a second worker that joins
gets half of the work once the first hands its excess over (``release``).
A lease that is not renewed expires, and the next tick of another worker
takes it: a worker that dies loses its sources within one lease time.
"""

from __future__ import annotations

from dataclasses import dataclass

from redis.asyncio import Redis

from .broker import WANTS_JSON, WORKERS, lease_key

TICK = """
local id, ttl = ARGV[1], tonumber(ARGV[2])
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
redis.call('ZADD', KEYS[1], now + ttl, id)
redis.call('ZREMRANGEBYSCORE', KEYS[1], '-inf', now)
local fair = math.ceil((#KEYS - 2) / redis.call('ZCARD', KEYS[1]))
local held, free = {}, {}
for i = 3, #KEYS do
  local holder = redis.call('GET', KEYS[i])
  if holder == id then
    redis.call('PEXPIRE', KEYS[i], ttl)
    held[#held + 1] = i - 2
  elseif not holder then
    free[#free + 1] = i - 2
  end
end
local taken = {}
for _, i in ipairs(free) do
  if #held + #taken >= fair then break end
  redis.call('SET', KEYS[i + 2], id, 'PX', ttl)
  taken[#taken + 1] = i
end
return {held, taken, fair, redis.call('EXISTS', KEYS[2])}
"""
"""KEYS: workers, wants:1, the lease of every source. ARGV: worker id, lease (ms)."""

RELEASE = """
local n = 0
for i = 1, #KEYS do
  if redis.call('GET', KEYS[i]) == ARGV[1] then
    redis.call('DEL', KEYS[i])
    n = n + 1
  end
end
return n
"""
"""KEYS: leases to give up if still held by ARGV[1] (the worker id)."""


@dataclass(frozen=True)
class Tick:
    """What one tick found: leases renewed and newly taken, the fair share, JSON wanted."""

    held: list[str]
    taken: list[str]
    fair: int
    json_wanted: bool

    @property
    def excess(self) -> list[str]:
        """Sources beyond the fair share, to hand over (the last ones held)."""
        mine = self.held + self.taken
        return mine[self.fair :] if len(mine) > self.fair else []


class Leases:
    """One worker's side of the leases."""

    def __init__(self, redis: Redis, worker: str, lease_s: float) -> None:
        self.worker = worker
        self.lease_ms = max(1, round(lease_s * 1000))
        self._redis = redis
        self._tick = redis.register_script(TICK)
        self._release = redis.register_script(RELEASE)

    async def tick(self, sources: list[str]) -> Tick:
        """Renew, take up to the fair share of ``sources``; raises RedisError or OSError."""
        keys = [WORKERS, WANTS_JSON, *map(lease_key, sources)]
        held, taken, fair, wanted = await self._tick(keys=keys, args=[self.worker, self.lease_ms])
        return Tick(
            held=[sources[i - 1] for i in held],
            taken=[sources[i - 1] for i in taken],
            fair=int(fair),
            json_wanted=bool(wanted),
        )

    async def release(self, sources: list[str]) -> int:
        """Give up the leases of ``sources`` still held; how many were."""
        if not sources:
            return 0
        count = await self._release(keys=[*map(lease_key, sources)], args=[self.worker])
        return int(count)

    async def leave(self, sources: list[str]) -> None:
        """Give up every lease and leave the live workers (a clean shutdown)."""
        await self.release(sources)
        await self._redis.zrem(WORKERS, self.worker)
