"""The UDP endpoint without a network: which datagrams are the connected client's commands.

libfranka answers each state to wherever it came from, from the source address its route
gives it; behind an address translation (Docker's userland proxy, a client connecting to the
host's own address) that is not the address its TCP connection came from. Its answers are
then taken from where they come, while its states keep going to the TCP peer; anything else
from another address is dropped. A socket stand-in records what is sent.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from franka_sim.protocol.codec import encode_command
from franka_sim.faults.link import ArmLink
from franka_sim.server.udp_endpoint import UdpEndpoint

PEER = ("10.0.0.5", 40000)  # the TCP peer and the port it announced
GATEWAY = ("172.17.0.1", 51000)  # where its answers come from behind the translation
STRANGER = ("10.0.0.9", 40000)


class Wire:
    """A socket stand-in: what was sent, and to where; datagrams waiting to be read."""

    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple]] = []
        self.inbox: list[tuple[bytes, tuple]] = []

    def sendto(self, data: bytes, target) -> None:
        self.sent.append((data, target))

    def recvfrom(self, size: int) -> tuple[bytes, tuple]:
        if not self.inbox:
            raise BlockingIOError
        return self.inbox.pop(0)


def _state(message_id: int) -> bytes:
    return message_id.to_bytes(8, "little") + b"\0" * 32  # the endpoint reads message_id only


def _endpoint() -> tuple[UdpEndpoint, list, Wire]:
    """An endpoint on a Wire whose `datagram_received(data, addr)` puts a datagram on it and
    reads what the endpoint takes into `taken`, as the cycle thread does."""
    taken: list = []
    endpoint = UdpEndpoint()
    endpoint.sock = wire = Wire()

    def received(data: bytes, addr) -> None:
        wire.inbox.append((data, addr))
        taken.extend(endpoint.read())
    endpoint.datagram_received = received
    endpoint.connect(*PEER)
    return endpoint, taken, wire


def _sent_states(endpoint: UdpEndpoint, *message_ids: int) -> None:
    for message_id in message_ids:
        endpoint.send_state(_state(message_id))


def _taken_ids(taken: list) -> list[int]:
    return [int(command["message_id"]) for command in taken]


def test_commands_from_the_tcp_peer_are_taken_and_nothing_moves():
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 100, 101)
    endpoint.datagram_received(encode_command(message_id=101), PEER)
    assert _taken_ids(taken) == [101]
    assert endpoint.source == PEER and endpoint.sources_moved == 0


def test_an_answer_through_a_translation_moves_the_source_once_with_one_log_line(caplog):
    endpoint, taken, wire = _endpoint()
    _sent_states(endpoint, 100, 101, 102)
    with caplog.at_level(logging.INFO, logger="franka_sim.server.udp_endpoint"):
        endpoint.datagram_received(encode_command(message_id=102), GATEWAY)
        _sent_states(endpoint, 103)
        endpoint.datagram_received(encode_command(message_id=103), GATEWAY)
        _sent_states(endpoint, 104)
        endpoint.datagram_received(encode_command(message_id=104), GATEWAY)
    assert _taken_ids(taken) == [102, 103, 104]
    assert endpoint.source == GATEWAY and endpoint.sources_moved == 1
    assert endpoint.dropped_foreign == 0
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1, lines
    assert "10.0.0.5" in lines[0] and "172.17.0.1:51000" in lines[0]  # both addresses
    assert {target for _, target in wire.sent} == {PEER}  # states still go to the TCP peer


def test_any_state_this_connection_was_sent_may_be_echoed():
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 100, 101, 102)
    endpoint.datagram_received(encode_command(message_id=100), GATEWAY)  # an older state
    assert _taken_ids(taken) == [100] and endpoint.source == GATEWAY


@pytest.mark.parametrize("datagram", [
    encode_command(message_id=99),  # a state sent before this connection's first
    encode_command(message_id=103),  # a state not sent yet
    encode_command(message_id=0),
    encode_command(message_id=101)[:-1],  # not a RobotCommand's size
    encode_command(message_id=101) + b"\0",
    b"garbage",
], ids=["before", "future", "zero", "short", "long", "garbage"])
def test_anything_else_from_another_address_is_dropped_and_counted(datagram, caplog):
    endpoint, taken, _ = _endpoint()
    endpoint.send_state(_state(99))
    endpoint.connect(*PEER)  # a new connection: what the last one was sent is not its own
    _sent_states(endpoint, 100, 101, 102)
    with caplog.at_level(logging.INFO, logger="franka_sim.server.udp_endpoint"):
        endpoint.datagram_received(datagram, STRANGER)
    assert taken == [] and endpoint.source == PEER
    assert endpoint.dropped_foreign == 1 and endpoint.sources_moved == 0
    assert "not the connected client" in caplog.text


def test_nothing_is_taken_from_elsewhere_before_a_state_was_sent_or_after_the_client_left():
    endpoint, taken, _ = _endpoint()
    endpoint.datagram_received(encode_command(message_id=0), GATEWAY)
    _sent_states(endpoint, 5)
    endpoint.disconnect()
    endpoint.datagram_received(encode_command(message_id=5), GATEWAY)
    endpoint.datagram_received(encode_command(message_id=5), PEER)
    assert taken == [] and endpoint.dropped_foreign == 2 and endpoint.dropped_departed == 1
    assert endpoint.source is None and endpoint.sources_moved == 0


def test_a_new_connection_starts_from_its_tcp_peer_again(caplog):
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 10)
    endpoint.datagram_received(encode_command(message_id=10), GATEWAY)
    endpoint.disconnect()
    endpoint.connect(*PEER)
    assert endpoint.source == PEER
    _sent_states(endpoint, 11)
    with caplog.at_level(logging.INFO, logger="franka_sim.server.udp_endpoint"):
        endpoint.datagram_received(encode_command(message_id=11), GATEWAY)
    assert _taken_ids(taken) == [10, 11] and endpoint.sources_moved == 2
    assert len(caplog.records) == 1  # each connection's first move is logged


def test_a_stranger_echoing_a_sent_message_id_is_taken_for_the_client():
    """The documented price: a datagram that looks like this connection's answer is taken,
    and the client's next answer moves the source back."""
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 100)
    endpoint.datagram_received(encode_command(message_id=100), STRANGER)
    _sent_states(endpoint, 101)
    endpoint.datagram_received(encode_command(message_id=101), PEER)
    assert _taken_ids(taken) == [100, 101]
    assert endpoint.source == PEER and endpoint.sources_moved == 2


def test_under_injected_faults_moved_answers_pass_the_link_and_states_keep_their_target():
    endpoint, taken, wire = _endpoint()
    link = ArmLink(0)
    link.new_client(endpoint.target)
    endpoint.faults = link
    _sent_states(endpoint, 200)
    endpoint.datagram_received(encode_command(message_id=200), GATEWAY)
    assert _taken_ids(taken) == [200]
    assert link.answered and link.client == PEER  # the driver's lockstep question is answered
    _sent_states(endpoint, 201)
    assert link.client == PEER and wire.sent[-1][1] == PEER


def test_the_clients_own_datagram_goes_straight_to_decoding():
    """The normal case costs one comparison: the other path (which reads the sent states) is
    not consulted."""
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 7)
    endpoint._from_elsewhere = lambda *_: pytest.fail("consulted for the client's own datagram")
    endpoint.datagram_received(encode_command(message_id=7, q_c=np.zeros(7)), PEER)
    assert _taken_ids(taken) == [7]


def test_what_the_client_sent_before_it_saw_its_connection_close_is_dropped_without_a_warning(
        caplog):
    endpoint, taken, _ = _endpoint()
    _sent_states(endpoint, 5)
    endpoint.disconnect()  # (the Desk cut it off, or it left mid-motion)
    with caplog.at_level(logging.INFO, logger="franka_sim.server.udp_endpoint"):
        endpoint.datagram_received(encode_command(message_id=5), PEER)
    assert taken == [] and endpoint.dropped_departed == 1 and endpoint.dropped_foreign == 0
    assert caplog.text == ""
    endpoint.connect(*GATEWAY)  # the next client: the last one's address is a stranger's
    with caplog.at_level(logging.INFO, logger="franka_sim.server.udp_endpoint"):
        endpoint.datagram_received(b"garbage", PEER)
    assert endpoint.dropped_foreign == 1 and "not the connected client" in caplog.text
