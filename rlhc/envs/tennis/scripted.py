"""placeholder"""


class ScriptedTennisPolicy: ...
