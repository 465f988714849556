"""An arm's Desk operations (desk/state.py: its brakes, operating mode, FCI and pilot
buttons), mixed into ArmOps: the Desk is made when first asked for, so a robot whose Desk
nobody calls never imports it; what the Desk's state means for the robot's endpoints is applied
by `desk_effects` (the server's DeskEffects.apply; replay and tests: None, nothing to open)."""

from __future__ import annotations

from franka_sim.control.errors import BadRequest


class DeskOps:
    """Mixed into ArmOps, which sets `desk_boot`, `desk_effects`, `description`, `core`,
    `lock`, `driver` and `_job` (operations/arm.py)."""

    _desk = None

    @property
    def desk_state(self):
        if self._desk is None:
            from franka_sim.desk.state import Desk

            self._desk = Desk(boot=self.desk_boot, robot=self.description.name)
        return self._desk

    async def _desk_applied(self) -> None:
        """After a reset: the Desk as it boots, and the robot's endpoints as it says."""
        if self._desk is None:
            return  # never asked for: as it booted
        self._desk.power_on()
        if self.desk_effects is not None:
            await self.desk_effects()

    def desk(self) -> dict:
        return self.desk_state.snapshot()

    def press_pilot_button(self, button) -> dict:
        from franka_sim.desk.state import DeskRefusal

        try:
            self.desk_state.press(button)
        except DeskRefusal as refusal:
            raise BadRequest(refusal.message) from None
        return self.desk()

    async def desk_arm(self, brakes=None, operating_mode=None) -> dict:
        """The brakes and the operating mode as at the robot (neither given: as the Desk
        says now, which is how the Desk's own calls end here); the arm held or freed in one
        job, recorded with the Desk's whole arm state, which replay sets again."""
        from franka_sim.desk.state import UNLOCKED, DeskRefusal

        desk = self.desk_state
        try:
            desk.set_arm(brakes, operating_mode)
        except DeskRefusal as refusal:
            raise BadRequest(refusal.message) from None
        held = not desk.arm_ready
        why = ("the Desk locked the brakes" if desk.brakes != UNLOCKED
               else f"the Desk left Execution ({desk.operating_mode})")

        def hold(world, arm) -> dict:
            with self.lock:
                self.core.hold(held, why)
            self.driver.keep_running()
            return self.desk()
        return await self._job(hold, ("desk_arm", {
            "brakes": desk.brakes, "operating_mode": desk.operating_mode}))
