#!/usr/bin/python3
"""A TCP relay that emulates a radio link between the sender and the service: a shared rate per direction, a one-way
delay, random loss (a lost 1448-byte segment costs a TCP retransmission timeout, max(200 ms, 2 x delay)), and
outages (SIGUSR1 starts one of --outage-s seconds: nothing crosses, new connections hang; what was in flight is
delivered after it, as TCP would once the link returns, unless the sender gave up and closed first).

Used by bench/stream_bench.sh because this kernel has no sch_netem (tc qdisc netem: "Specified qdisc kind is
unknown"); network namespaces and tbf do work here. On SIGTERM it writes its counters as JSON to --stats.
"""
import argparse
import asyncio
import json
import random
import signal
import time

SEGMENT = 1448


class Link:
    def __init__(self, kbps, delay_s, loss):
        self.rate = kbps * 1000.0 / 8.0  # bytes/s
        self.delay = delay_s
        self.loss = loss
        self.free_at = 0.0               # when the line is next free
        self.bytes = 0
        self.busy_s = 0.0

    def schedule(self, n, now, outage_end):
        start = max(now, self.free_at, outage_end)
        tx = n / self.rate
        segments = max(1, (n + SEGMENT - 1) // SEGMENT)
        lost = sum(1 for _ in range(segments) if random.random() < self.loss) if self.loss > 0 else 0
        self.free_at = start + tx
        self.bytes += n
        self.busy_s += tx
        return start + tx + self.delay + lost * max(0.2, 2 * self.delay)


class Relay:
    def __init__(self, args):
        self.args = args
        self.up = Link(args.kbps, args.delay_ms / 1000.0, args.loss)
        self.down = Link(args.kbps, args.delay_ms / 1000.0, args.loss)
        self.outage_end = 0.0
        self.outages = []
        self.connections = 0

    def start_outage(self):
        now = time.monotonic()
        self.outage_end = now + self.args.outage_s
        self.outages.append({"start_unix": time.time(), "seconds": self.args.outage_s})

    async def pipe(self, reader, writer, link):
        queue = asyncio.Queue()

        async def deliver():
            while True:
                item = await queue.get()
                if item is None:
                    break
                at, data = item
                wait = at - time.monotonic()
                if wait > 0:
                    await asyncio.sleep(wait)
                writer.write(data)
                await writer.drain()

        task = asyncio.ensure_future(deliver())
        try:
            while True:
                data = await reader.read(SEGMENT * 4)
                if not data:
                    break
                now = time.monotonic()
                outage_end = self.outage_end if self.outage_end > now else 0.0
                await queue.put((link.schedule(len(data), now, outage_end), data))
            await queue.put(None)
            await task
        except (ConnectionError, asyncio.CancelledError):
            task.cancel()
        finally:
            try:
                writer.close()
            except Exception:
                pass

    async def handle(self, client_reader, client_writer):
        self.connections += 1
        # A connection opened during an outage waits for its end (a SYN that gets through only then).
        while self.outage_end > time.monotonic():
            await asyncio.sleep(0.05)
        try:
            server_reader, server_writer = await asyncio.open_connection(self.args.target_host, self.args.target_port)
        except OSError:
            client_writer.close()
            return
        up = asyncio.ensure_future(self.pipe(client_reader, server_writer, self.up))
        down = asyncio.ensure_future(self.pipe(server_reader, client_writer, self.down))
        done, pending = await asyncio.wait([up, down], return_when=asyncio.FIRST_COMPLETED)
        # One side closed: the other goes too (a sender that gave up drops what was queued for it).
        for t in pending:
            t.cancel()
        for w in (client_writer, server_writer):
            try:
                w.close()
            except Exception:
                pass

    def stats(self):
        return {"kbps": self.args.kbps, "delay_ms": self.args.delay_ms, "loss": self.args.loss,
                "up_bytes": self.up.bytes, "up_busy_s": self.up.busy_s,
                "down_bytes": self.down.bytes, "connections": self.connections, "outages": self.outages}


async def main():
    p = argparse.ArgumentParser()
    p.add_argument("--listen-port", type=int, required=True)
    p.add_argument("--target-host", default="127.0.0.1")
    p.add_argument("--target-port", type=int, required=True)
    p.add_argument("--kbps", type=float, required=True)
    p.add_argument("--delay-ms", type=float, default=50)
    p.add_argument("--loss", type=float, default=0.0)
    p.add_argument("--outage-s", type=float, default=10)
    p.add_argument("--stats", required=True)
    args = p.parse_args()
    relay = Relay(args)
    loop = asyncio.get_running_loop()
    stop = loop.create_future()
    loop.add_signal_handler(signal.SIGUSR1, relay.start_outage)
    loop.add_signal_handler(signal.SIGTERM, lambda: stop.done() or stop.set_result(True))
    server = await asyncio.start_server(relay.handle, "127.0.0.1", args.listen_port)
    print("relay listening on", args.listen_port, flush=True)
    await stop
    server.close()
    with open(args.stats, "w") as f:
        json.dump(relay.stats(), f)


asyncio.run(main())
