"""Services and clients the way rmw_cyclonedds puts them on the wire.

Request topic `rq/<name>Request`, reply topic `rr/<name>Reply`; every payload is the XCDR1
header, a uint64 client guid (the instance handle of the client's request writer), an int64
sequence number, then the request or response fields. Endpoints carry `clientid=` /
`serviceid=` in USER_DATA (participant GUID prefix + a big-endian counter, printed as
rmw_cyclonedds does) so a server can tell when a client's reply reader has matched.
"""
from __future__ import annotations

import dataclasses
import itertools
import threading
import time
from collections.abc import Callable
from typing import Any

from cyclonedds.core import Policy, ReadCondition
from cyclonedds.idl import IdlMeta, IdlStruct
from cyclonedds.idl import types as t
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from . import names
from .entities import ANY_STATE, endpoint_user_data
from .graph import gid_of
from .qos import QoSProfile, to_dds
from .task import Future

_WRAPPERS: dict[type, type] = {}
_WRAPPER_LOCK = threading.Lock()
_HEADER = ("client_guid_", "sequence_number_")
# How long a server waits for a client's reply reader to match before replying anyway.
_REPLY_MATCH_WAIT_S = 0.5


def wire_type(msg_cls: type) -> type:
    """The DDS type of a request/response topic: header fields, then the message's fields,
    under the message's own DDS type name."""
    with _WRAPPER_LOCK:
        cls = _WRAPPERS.get(msg_cls)
        if cls is None:
            typename = msg_cls.__idl_typename__
            ns = IdlMeta.__prepare__(msg_cls.__name__, (IdlStruct,), typename=typename)
            ns["__annotations__"].update({_HEADER[0]: t.uint64, _HEADER[1]: t.int64})
            ns[_HEADER[0]] = dataclasses.field(default=0)
            ns[_HEADER[1]] = dataclasses.field(default=0)
            for f in dataclasses.fields(msg_cls):
                ns["__annotations__"][f.name] = msg_cls.__annotations__[f.name]
                ns[f.name] = dataclasses.field(default=None)
            cls = dataclasses.dataclass(IdlMeta(msg_cls.__name__, (IdlStruct,), ns,
                                                typename=typename))
            _WRAPPERS[msg_cls] = cls
        return cls


def wrap(msg: Any, guid: int, seq: int) -> Any:
    fields = {f.name: getattr(msg, f.name) for f in dataclasses.fields(msg)}
    return wire_type(type(msg))(**{_HEADER[0]: guid, _HEADER[1]: seq}, **fields)


def unwrap(sample: Any, msg_cls: type) -> Any:
    return msg_cls(**{f.name: getattr(sample, f.name) for f in dataclasses.fields(msg_cls)})


def csid_string(cs_id: bytes) -> str:
    """rmw_cyclonedds' text form: first byte as %2x, the others as .%x."""
    return f"{cs_id[0]:2x}" + "".join(f".{b:x}" for b in cs_id[1:])


def _user_data_key(qos: Any, key: str) -> str | None:
    ud = qos[Policy.Userdata] if qos is not None else None
    if ud is None:
        return None
    for item in ud.data.decode(errors="replace").split(";"):
        k, _, v = item.partition("=")
        if k == key:
            return v
    return None


class _Endpoints:
    """A writer and a reader sharing one client/service id."""

    def __init__(self, node: Any, srv_type: type, srv_name: str, qos: QoSProfile,
                 callback_group: Any, is_service: bool) -> None:
        self.srv_type = srv_type
        self.srv_name = srv_name
        self.qos_profile = qos
        self.callback_group = callback_group
        ctx = node.context
        participant = ctx.require_ok()
        req_topic, rep_topic = names.service_to_dds(srv_name)
        req_cls, rep_cls = srv_type.Request, srv_type.Response
        cs_id = gid_of(participant)[:12] + next(ctx.csid_counter).to_bytes(4, "big")
        key = "serviceid" if is_service else "clientid"
        self.cs_id = csid_string(cs_id)
        extra = f"{key}={self.cs_id};"
        if is_service:
            read_t, write_t, read_cls, write_cls = req_topic, rep_topic, req_cls, rep_cls
        else:
            read_t, write_t, read_cls, write_cls = rep_topic, req_topic, rep_cls, req_cls
        self._writer = DataWriter(participant, ctx.topic(write_t, wire_type(write_cls)), to_dds(
            qos, endpoint_user_data(write_cls._ros_type, extra), writer=True))
        self._reader = DataReader(participant, ctx.topic(read_t, wire_type(read_cls)), to_dds(
            qos, endpoint_user_data(read_cls._ros_type, extra), writer=False))
        self.condition = ReadCondition(self._reader, ANY_STATE)
        self.reader_gid = gid_of(self._reader)
        self.writer_gid = gid_of(self._writer)

    def destroy(self) -> None:
        self.condition.__del__()
        self._reader.__del__()
        self._writer.__del__()


class Service(_Endpoints):
    """rclpy.service.Service: `callback(request, response) -> response`."""

    def __init__(self, node: Any, srv_type: type, srv_name: str,
                 callback: Callable[[Any, Any], Any], qos: QoSProfile,
                 callback_group: Any) -> None:
        super().__init__(node, srv_type, srv_name, qos, callback_group, is_service=True)
        self.callback = callback
        self._logger = node.get_logger()

    def _take(self) -> Any:
        samples = self._reader.take(N=1)
        while samples and not samples[0].sample_info.valid_data:
            samples = self._reader.take(N=1)
        return samples[0] if samples else None

    def _execute(self, sample: Any) -> None:
        request = unwrap(sample, self.srv_type.Request)
        response = self.callback(request, self.srv_type.Response())
        if not isinstance(response, self.srv_type.Response):
            self._logger.error(f"service {self.srv_name}: callback returned {response!r}, "
                               "not a response; no reply sent")
            return
        self._await_client_reader(sample.sample_info.publication_handle)
        self._writer.write(wrap(response, sample.client_guid_, sample.sequence_number_))

    def _await_client_reader(self, request_writer: int) -> None:
        """Wait (bounded) until the reply writer matches the requesting client's reader, as
        rmw_cyclonedds does, so a reply is not sent before anyone can receive it."""
        try:
            info = self._reader.get_matched_publication_data(request_writer)
        except Exception:  # noqa: BLE001 - the client left already
            return
        clientid = _user_data_key(info.qos if info else None, "clientid")
        if clientid is None:
            return
        end = time.monotonic() + _REPLY_MATCH_WAIT_S
        while time.monotonic() < end:
            for handle in self._writer.get_matched_subscriptions():
                data = self._writer.get_matched_subscription_data(handle)
                if _user_data_key(data.qos if data else None, "clientid") == clientid:
                    return
            time.sleep(0.005)


class Client(_Endpoints):
    """rclpy.client.Client: call_async returns a Future completed by the executor."""

    def __init__(self, node: Any, srv_type: type, srv_name: str, qos: QoSProfile,
                 callback_group: Any) -> None:
        super().__init__(node, srv_type, srv_name, qos, callback_group, is_service=False)
        self._guid = self._writer.get_instance_handle() & 0xFFFF_FFFF_FFFF_FFFF  # as uint64
        self._seq = itertools.count(1)
        self._pending: dict[int, Future] = {}
        self._lock = threading.Lock()
        self._context = node.context

    def service_is_ready(self) -> bool:
        """True when one service's request reader and reply writer both match us."""
        req = {_user_data_key(self._match(self._writer, h, True), "serviceid")
               for h in self._writer.get_matched_subscriptions()}
        rep = {_user_data_key(self._match(self._reader, h, False), "serviceid")
               for h in self._reader.get_matched_publications()}
        return bool(req & rep)

    @staticmethod
    def _match(entity: Any, handle: int, subscription: bool) -> Any:
        try:
            data = (entity.get_matched_subscription_data(handle) if subscription
                    else entity.get_matched_publication_data(handle))
        except Exception:  # noqa: BLE001 - the endpoint went away meanwhile
            return None
        return data.qos if data else None

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        end = None if timeout_sec is None else time.monotonic() + timeout_sec
        while self._context.ok():
            if self.service_is_ready():
                return True
            if end is not None and time.monotonic() >= end:
                return False
            time.sleep(0.01)
        return False

    def call_async(self, request: Any) -> Future:
        if not isinstance(request, self.srv_type.Request):
            raise TypeError(f"expected {self.srv_type.Request._ros_type}, "
                            f"got {type(request).__name__}")
        future = Future()
        seq = next(self._seq)
        with self._lock:
            self._pending[seq] = future
        future.add_done_callback(lambda f: self._forget(seq) if f.cancelled() else None)
        self._writer.write(wrap(request, self._guid, seq))
        return future

    def call(self, request: Any, timeout_sec: float | None = None) -> Any:
        """Blocking call; needs an executor spinning this node in another thread."""
        future = self.call_async(request)
        if not future.wait(timeout_sec):
            future.cancel()
            raise TimeoutError(f"no reply from {self.srv_name} within {timeout_sec} s")
        return future.result()

    def _forget(self, seq: int) -> None:
        with self._lock:
            self._pending.pop(seq, None)

    def _take(self) -> Any:
        while True:
            samples = self._reader.take(N=1)
            if not samples:
                return None
            s = samples[0]
            # Replies to other clients of the same service arrive here too: keep only ours.
            if s.sample_info.valid_data and s.client_guid_ == self._guid:
                with self._lock:
                    future = self._pending.pop(s.sequence_number_, None)
                if future is not None:
                    return future, unwrap(s, self.srv_type.Response)

    def _execute(self, data: Any) -> None:
        future, response = data
        future.set_result(response)
