"""The network-fault operations, alike on every robot (each arm, the mobile base): its own UDP
path is robot `robot_index` of the world's NetworkFaults (server/network_faults.py), reached by duck
typing: `check(fields)`, `set(index, spec, seed)`, `report(index)`."""

from __future__ import annotations

from franka_sim.control.errors import BadRequest, NotFound


class FaultOps:
    """Mixed into a robot's operations, which set `worker` (the cycle thread: `call`),
    `network_faults` (None: none can be injected) and `robot_index`."""

    worker = None
    network_faults = None
    robot_index = 0

    async def faults(self) -> dict:
        """What is injected on this robot's path, and what it did so far."""
        network, index = self._network(), self.robot_index
        return await self.worker.call(lambda physics: network.report(index))

    async def set_faults(self, fields: dict) -> dict:
        """Inject `fields` (the spec's fields, or {"spec": "..."}; "seed" optional: the
        server's --seed) on this robot's path from the next datagram on, in place of what
        was."""
        network, index = self._network(), self.robot_index
        try:
            spec, seed = network.check(fields)
        except ValueError as exc:  # (a FaultSpecError is one)
            raise BadRequest(str(exc)) from None

        def inject(physics) -> dict:
            network.set(index, spec, seed)
            return network.report(index)
        return await self.worker.call(inject)

    async def clear_faults(self) -> dict:
        """No more faults on this robot's path; what they did is still reported."""
        network, index = self._network(), self.robot_index

        def clear(physics) -> dict:
            network.set(index, None)
            return network.report(index)
        return await self.worker.call(clear)

    def _network(self):
        if self.network_faults is None:
            raise NotFound("this simulator cannot inject network faults")
        return self.network_faults
