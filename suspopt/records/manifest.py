"""The kinds of run directory and the manifest that names one (``manifest.json``).

Every run directory holds one document record: its kind decides the file
(:data:`DOCUMENTS`). The manifest names the kind, the format of the records
(:data:`~suspopt.records.codec.FORMAT`) and the file; ``suspopt report`` reads it first and
dispatches on the kind, never on which files happen to exist."""

from __future__ import annotations

from dataclasses import dataclass

from suspopt.records.codec import FORMAT, Node, Record
from suspopt.records.codesign import CodesignStudy
from suspopt.records.compare import CompareStudy
from suspopt.records.coupling import CouplingStudy
from suspopt.records.pareto import ParetoFront
from suspopt.records.robust import RobustStudy
from suspopt.records.solve import SolveRecord
from suspopt.records.spectral import SpectralRecord
from suspopt.records.twostep import TwoStepStudy

MANIFEST = 'manifest.json'

#: kind → (record type, file name)
DOCUMENTS: dict[str, tuple[type[Record], str]] = {
    'solve': (SolveRecord, 'result.json'),
    'study': (TwoStepStudy, 'study.json'),
    'pareto': (ParetoFront, 'pareto.json'),
    'robust': (RobustStudy, 'robust.json'),
    'compare': (CompareStudy, 'compare.json'),
    'coupling': (CouplingStudy, 'coupling.json'),
    'spectral': (SpectralRecord, 'spectral.json'),
    'codesign': (CodesignStudy, 'codesign.json'),
}


@dataclass(frozen=True)
class Manifest(Record):
    """What a run directory holds: a record of ``kind`` in ``record``, in ``format``."""

    kind: str
    format: int
    record: str
    suspopt_version: str = ''

    @classmethod
    def of(cls, record: Record, version: str = '') -> Manifest:
        kind = record.KIND
        if kind not in DOCUMENTS:
            raise ValueError(f'{type(record).__name__} is not a document record')
        return cls(kind, FORMAT, DOCUMENTS[kind][1], version)

    @property
    def record_type(self) -> type[Record]:
        return DOCUMENTS[self.kind][0]

    def check(self, node: Node) -> None:
        if self.kind not in DOCUMENTS:
            raise node.child('kind').error(
                f'not a kind of run ({", ".join(DOCUMENTS)}), got {self.kind!r}'
            )
        if self.format != FORMAT:
            raise node.child('format').error(
                f'format {self.format} is not the format {FORMAT} of this suspopt '
                '(written by another version; re-run it with this one)'
            )
        if self.record != DOCUMENTS[self.kind][1]:
            raise node.child('record').error(
                f'a {self.kind} run writes {DOCUMENTS[self.kind][1]}, got {self.record!r}'
            )


def file_of(record: Record) -> str:
    """The file a document record is written to."""
    if record.KIND not in DOCUMENTS:
        raise ValueError(f'{type(record).__name__} is not a document record')
    return DOCUMENTS[record.KIND][1]
