"""Many messages of one channel into an MCAP file at once: the bytes `Writer.add_message`
writes for each, one after the other, at a fifth of its cost. The recorder's per-sample
/plot topics send a message per sample (1,000 a second a channel); through add_message
they cost as much as the plant's physics. This reaches into mcap 1.6's writer (pinned in
pyproject.toml); tests/test_wire_formats.py checks the bytes against add_message's."""
from __future__ import annotations

import struct
from itertools import chain

from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

MESSAGE = 0x05  # the Message record's opcode
_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel id, sequence, log time, publish time
_FIXED = 22  # the record's length before its data: channel id, sequence and the two times


class _Index(MessageIndex):
    """A chunk's index of one channel's messages, its entries packed at once (the
    library packs each time and offset apart, as much again as the messages cost)."""

    def write(self, stream):
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(len(self.records) * 16)
        stream.write(struct.pack(f"<{2 * len(self.records)}Q", *chain.from_iterable(self.records)))
        stream.finish_record()


def add_messages(w: Writer, channel_id: int, log_times: list[int], datas: list[bytes], sequence: int) -> None:
    """w.add_message(channel_id, t, data, t, sequence=sequence + i) for each (t, data) in order."""
    chunk = getattr(w, "_Writer__chunk_builder", None)
    if chunk is None or not log_times:  # unchunked: as the library writes it
        for i, (t, data) in enumerate(zip(log_times, datas)):
            w.add_message(channel_id, t, data, t, sequence=sequence + i)
        return
    stats = w._Writer__statistics
    stats.message_start_time = min(log_times) if stats.message_count == 0 else min(stats.message_start_time,
                                                                                  min(log_times))
    stats.message_end_time = max(stats.message_end_time, max(log_times))
    stats.channel_message_counts[channel_id] += len(log_times)
    stats.message_count += len(log_times)
    limit = w._Writer__chunk_size
    i, n = 0, len(log_times)
    while i < n:
        # the messages up to the one that takes the chunk past its size, which closes it
        buf, start = chunk.record_writer._buffer, chunk.record_writer.count
        offsets, records, end = [], [], start
        j = i
        while j < n:
            data = datas[j]
            offsets.append(end)
            records.append(_HEAD.pack(MESSAGE, _FIXED + len(data), channel_id, sequence + j, log_times[j],
                                      log_times[j]) + data)
            end += 9 + _FIXED + len(data)
            j += 1
            if end > limit:
                break
        ts = log_times[i:j]
        chunk.message_start_time = min(ts) if chunk.num_messages == 0 else min(chunk.message_start_time, min(ts))
        chunk.message_end_time = max(chunk.message_end_time, max(ts))
        index = chunk.message_indices.get(channel_id)
        if not index:
            index = chunk.message_indices[channel_id] = _Index(channel_id=channel_id, records=[])
        index.records.extend(zip(ts, offsets))
        chunk.num_messages += j - i
        buf.write(b"".join(records))
        if end > limit:
            w._Writer__finalize_chunk()
        i = j
