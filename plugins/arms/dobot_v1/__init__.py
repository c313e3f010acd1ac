"""The Dobot V1.0 arm: kinematics, both firmwares' protocols, emulators and drivers.

Modules
-------
``kinematics``          :class:`DobotV1Model`: Showers 2016's limits (eqs. 1-4, the coupled
                        elbow limit as a Constraint), FK (eqs. 5-7), analytic IK (eqs.
                        8-10, both elbow branches) and link boxes (eqs. 11-13), batched.
``codec``               the original firmware's 42-byte frames (Dobot protocol).
``emulator``            :class:`DobotV1Emulator`, the original firmware.
``driver``              :class:`DobotV1Driver`, one command per status frame.
``opendobot``           the open-dobot wire format: CRC-16/CCITT continuing into the
                        reply, step encodings of the FPGA and RAMPS boards (open-dobot).
``opendobot_emulator``  :class:`OpenDobotEmulator`: 100-slot queue at 50 Hz, accelerometer
                        boot pose, limit-switch calibrator, e-stop.
``opendobot_driver``    :class:`OpenDobotDriver`: host-planned moves streamed slot by slot.
``plugin``              registers ``arm: {type: dobot_v1}`` (``firmware: original`` or
                        ``open-dobot``).

Emulation choices where the public sources are silent: the
original firmware streams status every 50 ms, keeps up to 4 queued moves, stops
and clears them on a jog stop (state 2/7, axis 0), runs MOVL points outside the
workspace by joint interpolation, and refuses (rather than loses control on)
unreachable state-3 targets. The open-dobot emulator's limit switches sit at 135, 85 and 95 degrees
and respond whatever pin is named. Joint speeds and accelerations are assumed
(the report gives none): 90 deg/s and 180 deg/s^2 for the base, 60 and 120 for
the arms.
"""
