"""Commands shared by the arm plugins (``armtree emulate``)."""
