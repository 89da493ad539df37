"""Slamtec's RPLIDAR serial protocol (A1 series, protocol v2.x), both directions, no I/O.

The packaged RPLIDAR libraries (``rplidar``, ``pyrplidar``, ``adafruit-circuitpython-rplidar``)
own the serial port and read it in blocking loops, so they can neither be fed bytes by the
host's non-blocking poll and the twin's lockstep loop nor speak the device's side; this module
is the codec both ends share instead.

Requests (host to device)::

    0xA5 CMD                                   commands without payload (bit 7 of CMD clear)
    0xA5 CMD SIZE PAYLOAD[SIZE] CHECKSUM       commands with payload (bit 7 of CMD set);
                                               CHECKSUM = XOR of every byte before it

Responses (device to host) start with a 7-byte descriptor::

    0xA5 0x5A  u32 LE: length (bits 0-29) | send mode (bits 30-31)  DATA_TYPE

followed by ``length`` bytes once (send mode 0, single) or by units of ``length`` bytes until
the host sends STOP (send mode 1, multiple). The ones the A1 driver uses:

=============== ====== ====================== ======== ====== ==========================
request         CMD    descriptor             mode     length payload
=============== ====== ====================== ======== ====== ==========================
STOP            0x25   none                                    -
RESET           0x40   none                                    -
SCAN            0x20   A5 5A 05 00 00 40 81   multiple 5      measurement nodes
GET_INFO        0x50   A5 5A 14 00 00 00 04   single   20     model u8, firmware minor u8,
                                                               major u8, hardware u8,
                                                               serial number 16 bytes
GET_HEALTH      0x52   A5 5A 03 00 00 00 06   single   3      status u8 (0 good,
                                                               1 warning, 2 error),
                                                               error code u16 LE
GET_SAMPLERATE  0x59   A5 5A 04 00 00 00 15   single   4      T standard u16 LE [us],
                                                               T express u16 LE [us]
FORCE_SCAN      0x21   A5 5A 05 00 00 40 81   multiple 5      as SCAN
EXPRESS_SCAN    0x82   by the mode's answer   multiple 84/132 capsules (below); request
                       type: 0x82, 0x84, 0x85                  payload: working mode u8,
                                                               working flags u16 LE,
                                                               param u16 LE
GET_LIDAR_CONF  0x84   A5 5A n 00 00 00 20    single   4 + k  entry type u32 LE, value
                                                               (k bytes); request payload:
                                                               entry type u32 LE, then the
                                                               scan mode id u16 LE for the
                                                               per-mode entries
=============== ====== ====================== ======== ====== ==========================

GET_LIDAR_CONF (firmware 1.24 and later, :class:`ConfType`) describes the scan modes a device
offers (:class:`ScanMode`); EXPRESS_SCAN with a mode's id as working mode starts it, and the
mode's answer type names the capsule format of its stream (:class:`CapsuleFormat`, and the
section "Express scans" below).

A standard measurement node is 5 bytes::

    byte 0  quality (bits 2-7) | !S (bit 1) | S (bit 0)     S: first node of a new turn
    byte 1  angle_q6 bits 0-6 (bits 1-7) | C (bit 0)        C: check bit, always 1
    byte 2  angle_q6 bits 7-14
    byte 3  distance_q2 LE low byte                          distance [mm] * 4; 0: no return
    byte 4  distance_q2 LE high byte

with ``angle_q6`` the heading [deg] * 64, measured clockwise seen from above. A node is valid
when exactly one of S and !S is set and C is 1; a node never begins with ``A5 5A`` (C would be
0), so a descriptor inside a node stream is unambiguous.

:class:`ResponseDecoder` (host side) and :class:`RequestDecoder` (device side) take arbitrary
chunks of a byte stream, return what they completed, count and skip the bytes that fit
nothing, and never raise on garbage. Nodes come out in :class:`NodeBatch` arrays, decoded
with numpy, as the host decodes about 8000 of them a second.
"""

from __future__ import annotations

from jackson.protocol.rplidar.conf import (
    PER_MODE_CONF_TYPES,
    Q8,
    ConfType,
    LidarConf,
    LidarConfQuery,
    ScanMode,
    decode_lidar_conf,
    decode_lidar_conf_query,
    encode_lidar_conf,
    encode_lidar_conf_query,
    lidar_conf_response,
    scan_mode_conf,
)
from jackson.protocol.rplidar.decoder import ResponseDecoder
from jackson.protocol.rplidar.express import (
    ANGLE_Q6_TURN,
    ANGLE_Q16_TURN,
    CAPSULE_DISTANCE_MM_MAX,
    CAPSULE_DTHETA_Q3_MAX,
    CAPSULE_FORMATS,
    CAPSULE_HEADER_BYTES,
    CAPSULE_START_BIT,
    CAPSULE_SYNC_1,
    CAPSULE_SYNC_2,
    CAPSULED,
    DENSE_CAPSULED,
    PREDICT_NONE,
    ULTRA_CAPSULED,
    ULTRA_OFFSET_FAR_RAD_Q16,
    ULTRA_OFFSET_K1,
    ULTRA_OFFSET_K3,
    ULTRA_OFFSET_NEAR_Q2,
    ULTRA_OFFSET_NEAR_RAD_Q16,
    ULTRA_OFFSET_PI,
    VBS_CODE_MAX,
    CapsuleDecoder,
    CapsuleFormat,
    ExpressScanRequest,
    I64Array,
    SampleBatch,
    capsule_format,
    decode_express_scan,
    encode_capsule,
    encode_dense_capsule,
    encode_express_scan,
    encode_ultra_cabins,
    encode_ultra_capsule,
    ultra_angle_offset_q16,
    ultra_capsule_of_cabins,
    varbitscale_decode,
    varbitscale_encode,
)
from jackson.protocol.rplidar.nodes import decode_node, decode_nodes, encode_node, encode_nodes
from jackson.protocol.rplidar.packets import (
    A1M8_SCAN_PERIOD_S,
    ANGLE_Q6_MAX,
    CMDFLAG_HAS_PAYLOAD,
    DESCRIPTOR_BYTES,
    DISTANCE_Q2_MAX,
    LENGTH_MASK,
    NODE_BYTES,
    QUALITY_MAX,
    SEND_MODE_SHIFT,
    SERIAL_BYTES,
    SYNC_BYTE,
    SYNC_BYTE2,
    BoolArray,
    Command,
    DataType,
    Descriptor,
    DeviceHealth,
    DeviceInfo,
    HealthStatus,
    MeasurementNode,
    NodeBatch,
    Request,
    ResponseItem,
    SampleRate,
    SendMode,
    U8Array,
    U16Array,
)
from jackson.protocol.rplidar.requests import RequestDecoder, encode_request
from jackson.protocol.rplidar.responses import (
    HEALTH_DESCRIPTOR,
    INFO_DESCRIPTOR,
    KNOWN_RESPONSES,
    SAMPLERATE_DESCRIPTOR,
    SCAN_DESCRIPTOR,
    decode_descriptor,
    decode_health,
    decode_info,
    decode_samplerate,
    encode_descriptor,
    encode_health,
    encode_info,
    encode_samplerate,
    response,
)

__all__ = [
    "A1M8_SCAN_PERIOD_S",
    "ANGLE_Q6_MAX",
    "ANGLE_Q6_TURN",
    "ANGLE_Q16_TURN",
    "CAPSULED",
    "CAPSULE_DISTANCE_MM_MAX",
    "CAPSULE_DTHETA_Q3_MAX",
    "CAPSULE_FORMATS",
    "CAPSULE_HEADER_BYTES",
    "CAPSULE_START_BIT",
    "CAPSULE_SYNC_1",
    "CAPSULE_SYNC_2",
    "CMDFLAG_HAS_PAYLOAD",
    "DENSE_CAPSULED",
    "DESCRIPTOR_BYTES",
    "DISTANCE_Q2_MAX",
    "HEALTH_DESCRIPTOR",
    "INFO_DESCRIPTOR",
    "KNOWN_RESPONSES",
    "LENGTH_MASK",
    "NODE_BYTES",
    "PER_MODE_CONF_TYPES",
    "PREDICT_NONE",
    "Q8",
    "QUALITY_MAX",
    "SAMPLERATE_DESCRIPTOR",
    "SCAN_DESCRIPTOR",
    "SEND_MODE_SHIFT",
    "SERIAL_BYTES",
    "SYNC_BYTE",
    "SYNC_BYTE2",
    "ULTRA_CAPSULED",
    "ULTRA_OFFSET_FAR_RAD_Q16",
    "ULTRA_OFFSET_K1",
    "ULTRA_OFFSET_K3",
    "ULTRA_OFFSET_NEAR_Q2",
    "ULTRA_OFFSET_NEAR_RAD_Q16",
    "ULTRA_OFFSET_PI",
    "VBS_CODE_MAX",
    "BoolArray",
    "CapsuleDecoder",
    "CapsuleFormat",
    "Command",
    "ConfType",
    "DataType",
    "Descriptor",
    "DeviceHealth",
    "DeviceInfo",
    "ExpressScanRequest",
    "HealthStatus",
    "I64Array",
    "LidarConf",
    "LidarConfQuery",
    "MeasurementNode",
    "NodeBatch",
    "Request",
    "RequestDecoder",
    "ResponseDecoder",
    "ResponseItem",
    "SampleBatch",
    "SampleRate",
    "ScanMode",
    "SendMode",
    "U8Array",
    "U16Array",
    "capsule_format",
    "decode_descriptor",
    "decode_express_scan",
    "decode_health",
    "decode_info",
    "decode_lidar_conf",
    "decode_lidar_conf_query",
    "decode_node",
    "decode_nodes",
    "decode_samplerate",
    "encode_capsule",
    "encode_dense_capsule",
    "encode_descriptor",
    "encode_express_scan",
    "encode_health",
    "encode_info",
    "encode_lidar_conf",
    "encode_lidar_conf_query",
    "encode_node",
    "encode_nodes",
    "encode_request",
    "encode_samplerate",
    "encode_ultra_cabins",
    "encode_ultra_capsule",
    "lidar_conf_response",
    "response",
    "scan_mode_conf",
    "ultra_angle_offset_q16",
    "ultra_capsule_of_cabins",
    "varbitscale_decode",
    "varbitscale_encode",
]
