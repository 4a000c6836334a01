"""The routing environment (SPEC section 6): KiCad holds and judges the board, pcbdata plans the
route geometry (`pcbdata.env.walkaround`)."""
