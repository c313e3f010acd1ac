"""BehaviorTree.CPP v4: trees as its XML in and out, and a live view in Groot2.

| module | job |
| --- | --- |
| ``xmlfile.py`` | XML read with every element's and attribute's position; DTDs refused (defusedxml) |
| ``values.py`` | parameter values as port strings and back; port types |
| ``mapping.py`` | armtree's node types matched to BT.CPP's built-ins, both ways |
| ``reader.py`` | a ``<BehaviorTree>`` as the data a YAML tree file gives (``armtree_read_tree``) |
| ``writer.py`` | a tree and its subtrees as XML with its ``<TreeNodesModel>``; the palette |
| ``export_command.py`` | ``armtree export`` |

See docs/tree_files.md ("BehaviorTree.CPP XML").
"""
