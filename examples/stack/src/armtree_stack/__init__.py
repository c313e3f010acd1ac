"""Stack tagged blocks with armtree's pick and place behaviours."""
