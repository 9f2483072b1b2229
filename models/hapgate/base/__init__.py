"""Foundation: paths of the tree, the Block/Params description, table writers, report tables
and plots, the strict capture CSV reader, the tool environment. Imports no other layer."""
