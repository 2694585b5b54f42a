"""Force elements: the protocol (:mod:`.base`) and every element a drive is built of."""
