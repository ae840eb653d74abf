"""What the equation is: the system and its user functions (``system``), systems written as formulas
(``expressions``)."""
