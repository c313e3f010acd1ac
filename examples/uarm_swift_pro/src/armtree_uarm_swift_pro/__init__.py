"""The uFactory uArm Swift Pro for armtree: its G-code dialect, kinematics and a firmware emulator."""
