"""The jackson wire protocol: frames, messages and their codecs (see protocol/spec.md).

Typical use on a receiver::

    decoder = FrameDecoder()
    for frame in decoder.feed(chunk, now_us):
        msg = decode_message(frame)

and on a sender ``port.write(encode_frame(msg, seq))``.
"""

from jackson.protocol.crc import crc32c
from jackson.protocol.errors import (
    EncodeError,
    FrameVersionError,
    ProtocolError,
    ProtocolMismatchError,
)
from jackson.protocol.frame import (
    MAX_FRAME,
    DecoderCounters,
    Frame,
    FrameDecoder,
    decode_message,
    encode_frame,
)
from jackson.protocol.handshake import check_peer, hello, new_session_id
from jackson.protocol.messages import (
    MAX_PAYLOAD,
    MESSAGES,
    PROTOCOL_VERSION,
    SCHEMA_HASH,
    Ack,
    Capabilities,
    Heartbeat,
    Hello,
    HostState,
    Info,
    Log,
    LogLevel,
    Message,
    MotorPwm,
    Nack,
    NackError,
    RequestInfo,
    SetConfig,
    SetImuCalibration,
    SetRate,
    Status,
    Telemetry,
    TelemetryFlags,
    ZeroCounters,
)
from jackson.protocol.timestamp import TimestampUnwrapper

__all__ = [
    "MAX_FRAME",
    "MAX_PAYLOAD",
    "MESSAGES",
    "PROTOCOL_VERSION",
    "SCHEMA_HASH",
    "Ack",
    "Capabilities",
    "DecoderCounters",
    "EncodeError",
    "Frame",
    "FrameDecoder",
    "FrameVersionError",
    "Heartbeat",
    "Hello",
    "HostState",
    "Info",
    "Log",
    "LogLevel",
    "Message",
    "MotorPwm",
    "Nack",
    "NackError",
    "ProtocolError",
    "ProtocolMismatchError",
    "RequestInfo",
    "SetConfig",
    "SetImuCalibration",
    "SetRate",
    "Status",
    "Telemetry",
    "TelemetryFlags",
    "TimestampUnwrapper",
    "ZeroCounters",
    "check_peer",
    "crc32c",
    "decode_message",
    "encode_frame",
    "hello",
    "new_session_id",
]
