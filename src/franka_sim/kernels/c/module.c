/* The module: its method table and initialisation. */
#include "kernels.h"

#define FASTCALL(name) {#name, (PyCFunction)(void (*)(void))name, METH_FASTCALL, NULL}
static PyMethodDef methods[] = {
    FASTCALL(drive_follow), FASTCALL(drive_impedance), FASTCALL(saturate_less),
    FASTCALL(torque_inside), FASTCALL(measured_inside), FASTCALL(joint_position_step),
    FASTCALL(friction_argument), FASTCALL(friction_torque), FASTCALL(add_feed_forward),
    FASTCALL(impedance_torque), FASTCALL(joint_follow), FASTCALL(doubles_within),
    FASTCALL(narrow_into), FASTCALL(bind_readings),
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "franka_sim.kernels._compiled",
    "The cycle's fused vector loops, compiled (see kernels/reference.py).", -1, methods,
    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__compiled(void)
{
    if (readings_type_ready() < 0)
        return NULL;
    return PyModule_Create(&module);
}
