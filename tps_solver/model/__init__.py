"""The model: free flight, the bouncing flat layer and its contact patterns, the sticking and chatter
orbits, the soft-contact flat orbit, harmonics and the linear stability of flat layers.  Imports only
``core``."""
