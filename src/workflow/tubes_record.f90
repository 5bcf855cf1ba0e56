!> A scene's result record (docs/development.md, "Scenes and their records"): what a scene
!> computed and decided, in the order it did, for a front end to print and write:
!>
!> - items: datasets (real or integer, any rank, with units) and strings, and attributes (real,
!>   integer, string), each with its group's path ('equilibria', 'orbits/bifurcations') and its
!>   name; arrays in C order (row-major: the last index fastest), as the HDF5 file holds them;
!> - lines: the console's lines, each to stdout or stderr;
!> - the exit code: the worst verdict's (0: none), docs/usage.md's EXIT_*.
!>
!> The scene procedures (src/workflow/tubes_scenes.f90) fill a record; the C driver walks it into
!> the output file and onto the console (src/io/tubes_record_write.c), Python reads it
!> (python/tubes_f2py.f90): one procedure, two thin front ends. Records between the Fortran core
!> and a front end are kept by handle (record_keep, record_at, record_drop).
module tubes_record
  use tubes_kinds, only: wp, i8
  implicit none
  private

  integer, parameter, public :: REC_REAL = 1, REC_INT = 2, REC_STRINGS = 3, REC_ATTR_REAL = 4, &
                                REC_ATTR_INT = 5, REC_ATTR_STRING = 6
  integer, parameter, public :: REC_STDOUT = 1, REC_STDERR = 2
  !> the program's exit codes (include/tubes_scenes.h, docs/usage.md)
  integer, parameter, public :: EXIT_BADINPUT = 1, EXIT_NUMERIC = 2, EXIT_IO = 3, EXIT_PARTIAL = 4

  !> One dataset or attribute.
  type, public :: rec_item_t
    integer :: kind = 0
    character(:), allocatable :: group, name, units   !! units '' : none written
    integer :: rank = 0
    integer(i8) :: dims(5) = 0         !! at most rank 5 (/flux/tube_cut/states)
    real(wp), allocatable :: r(:)
    integer, allocatable :: i(:)
    integer(i8), allocatable :: l(:)                  !! an integer attribute's value (64 bits)
    character(:), allocatable :: s(:)                 !! strings (REC_STRINGS, REC_ATTR_STRING)
  end type rec_item_t

  type, public :: rec_line_t
    integer :: stream = REC_STDOUT
    character(:), allocatable :: text
  end type rec_line_t

  type, public :: record_t
    type(rec_item_t), allocatable :: items(:)
    type(rec_line_t), allocatable :: lines(:)
    integer :: n_items = 0, n_lines = 0
    integer :: code = 0            !! the worst verdict's exit code
  contains
    procedure :: real => add_real
    procedure :: int => add_int
    procedure :: strings => add_strings
    procedure :: attr_real => add_attr_real
    procedure :: add_attr_int, add_attr_long
    generic :: attr_int => add_attr_int, add_attr_long
    procedure :: attr_string => add_attr_string
    procedure :: out => add_out
    procedure :: err => add_err
    procedure :: verdict => add_verdict
  end type record_t

  type :: kept_t
    type(record_t), allocatable :: rec
  end type kept_t
  type(kept_t), allocatable, target :: kept(:)   ! (a module variable: kept between calls)

  public :: record_keep, record_at, record_drop, record_sizes, record_item_info, record_reals, record_ints, &
            record_string, record_line, record_long

contains

  !> A new item's slot.
  function next_item(self) result(k)
    class(record_t), intent(inout) :: self
    integer :: k
    type(rec_item_t), allocatable :: more(:)
    if (.not. allocated(self%items)) allocate (self%items(16))
    if (self%n_items == size(self%items)) then
      allocate (more(2*size(self%items)))
      more(1:self%n_items) = self%items(1:self%n_items)
      call move_alloc(more, self%items)
    end if
    self%n_items = self%n_items + 1
    k = self%n_items
  end function next_item

  subroutine named(it, kind, group, name, units)
    type(rec_item_t), intent(inout) :: it
    integer, intent(in) :: kind
    character(*), intent(in) :: group, name
    character(*), intent(in), optional :: units
    it%kind = kind
    it%group = group
    it%name = name
    it%units = ''
    if (present(units)) it%units = units
  end subroutine named

  !> A real dataset of shape dims (C order: data holds the last index fastest).
  subroutine add_real(self, group, name, data, dims, units)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    real(wp), intent(in) :: data(:)
    integer, intent(in) :: dims(:)
    character(*), intent(in), optional :: units
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_REAL, group, name, units)
    self%items(k)%rank = size(dims)
    self%items(k)%dims(1:size(dims)) = dims
    self%items(k)%r = data
  end subroutine add_real

  !> An integer dataset of shape dims (C order).
  subroutine add_int(self, group, name, data, dims, units)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    integer, intent(in) :: data(:)
    integer, intent(in) :: dims(:)
    character(*), intent(in), optional :: units
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_INT, group, name, units)
    self%items(k)%rank = size(dims)
    self%items(k)%dims(1:size(dims)) = dims
    self%items(k)%i = data
  end subroutine add_int

  !> A dataset of strings (trailing blanks are not part of a string).
  subroutine add_strings(self, group, name, s)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    character(*), intent(in) :: s(:)
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_STRINGS, group, name)
    self%items(k)%rank = 1
    self%items(k)%dims(1) = size(s)
    self%items(k)%s = s
  end subroutine add_strings

  subroutine add_attr_real(self, group, name, v)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    real(wp), intent(in) :: v
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_ATTR_REAL, group, name)
    self%items(k)%r = [v]
  end subroutine add_attr_real

  subroutine add_attr_int(self, group, name, v)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    integer, intent(in) :: v
    call self%add_attr_long(group, name, int(v, i8))
  end subroutine add_attr_int

  !> An integer attribute of 64 bits (counters: a trajectory's evaluations can pass 2^31).
  subroutine add_attr_long(self, group, name, v)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name
    integer(i8), intent(in) :: v
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_ATTR_INT, group, name)
    self%items(k)%l = [v]
  end subroutine add_attr_long

  subroutine add_attr_string(self, group, name, v)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: group, name, v
    integer :: k
    k = next_item(self)
    call named(self%items(k), REC_ATTR_STRING, group, name)
    allocate (character(len(v)) :: self%items(k)%s(1))
    self%items(k)%s(1) = v
  end subroutine add_attr_string

  subroutine add_line(self, stream, text)
    class(record_t), intent(inout) :: self
    integer, intent(in) :: stream
    character(*), intent(in) :: text
    type(rec_line_t), allocatable :: more(:)
    if (.not. allocated(self%lines)) allocate (self%lines(16))
    if (self%n_lines == size(self%lines)) then
      allocate (more(2*size(self%lines)))
      more(1:self%n_lines) = self%lines(1:self%n_lines)
      call move_alloc(more, self%lines)
    end if
    self%n_lines = self%n_lines + 1
    self%lines(self%n_lines)%stream = stream
    self%lines(self%n_lines)%text = text
  end subroutine add_line

  !> A line of the console's stdout.
  subroutine add_out(self, text)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: text
    call add_line(self, REC_STDOUT, text)
  end subroutine add_out

  !> A line of stderr that is not a verdict (a note).
  subroutine add_err(self, text)
    class(record_t), intent(inout) :: self
    character(*), intent(in) :: text
    call add_line(self, REC_STDERR, text)
  end subroutine add_err

  !> A verdict: its message on stderr, and the run's exit code at least code.
  subroutine add_verdict(self, code, text)
    class(record_t), intent(inout) :: self
    integer, intent(in) :: code
    character(*), intent(in) :: text
    call add_line(self, REC_STDERR, text)
    self%code = max(self%code, code)
  end subroutine add_verdict

  !> Keep rec (moved in) for a front end: its handle (>= 1).
  integer function record_keep(rec) result(h)
    type(record_t), allocatable, intent(inout) :: rec
    type(kept_t), allocatable :: more(:)
    integer :: k
    if (.not. allocated(kept)) allocate (kept(4))
    h = 0
    do k = 1, size(kept)
      if (.not. allocated(kept(k)%rec)) then
        h = k
        exit
      end if
    end do
    if (h == 0) then
      allocate (more(2*size(kept)))
      do k = 1, size(kept)
        call move_alloc(kept(k)%rec, more(k)%rec)
      end do
      h = size(kept) + 1
      call move_alloc(more, kept)
    end if
    call move_alloc(rec, kept(h)%rec)
  end function record_keep

  !> The record of handle h (null if none).
  function record_at(h) result(p)
    integer, intent(in) :: h
    type(record_t), pointer :: p
    p => null()
    if (.not. allocated(kept)) return
    if (h < 1 .or. h > size(kept)) return
    if (allocated(kept(h)%rec)) p => kept(h)%rec
  end function record_at

  !> Forget the record of handle h.
  subroutine record_drop(h)
    integer, intent(in) :: h
    if (.not. allocated(kept)) return
    if (h < 1 .or. h > size(kept)) return
    if (allocated(kept(h)%rec)) deallocate (kept(h)%rec)
  end subroutine record_drop

  !> Record h's exit code (-1: no record) and its numbers of items and of console lines.
  subroutine record_sizes(h, code, n_items, n_lines)
    integer, intent(in) :: h
    integer, intent(out) :: code, n_items, n_lines
    type(record_t), pointer :: r
    r => record_at(h)
    code = -1
    n_items = 0
    n_lines = 0
    if (.not. associated(r)) return
    code = r%code
    n_items = r%n_items
    n_lines = r%n_lines
  end subroutine record_sizes

  !> Item k of record h (null if none).
  function item_at(h, k) result(it)
    integer, intent(in) :: h, k
    type(rec_item_t), pointer :: it
    type(record_t), pointer :: r
    it => null()
    r => record_at(h)
    if (.not. associated(r)) return
    if (k >= 1 .and. k <= r%n_items) it => r%items(k)
  end function item_at

  !> Item k of record h: its kind (REC_*), group, name, units, rank, dims (C order), its number of
  !> values n (strings: their count, slen the longest's length); n = -1: no such item.
  subroutine record_item_info(h, k, kind, group, name, units, rank, dims, n, slen)
    integer, intent(in) :: h, k
    integer, intent(out) :: kind, rank, n, slen
    character(:), allocatable, intent(out) :: group, name, units
    integer(i8), intent(out) :: dims(5)
    type(rec_item_t), pointer :: it
    kind = 0
    rank = 0
    n = -1
    slen = 0
    dims = 0
    group = ''
    name = ''
    units = ''
    it => item_at(h, k)
    if (.not. associated(it)) return
    kind = it%kind
    group = it%group
    name = it%name
    units = it%units
    rank = it%rank
    dims = it%dims
    if (allocated(it%r)) n = size(it%r)
    if (allocated(it%i)) n = size(it%i)
    if (allocated(it%l)) n = size(it%l)
    if (allocated(it%s)) then
      n = size(it%s)
      slen = len(it%s)
    end if
  end subroutine record_item_info

  !> Item k's real values (v's size of them, C order; 0 where it has none).
  subroutine record_reals(h, k, v)
    integer, intent(in) :: h, k
    real(wp), intent(out) :: v(:)
    type(rec_item_t), pointer :: it
    v = 0
    it => item_at(h, k)
    if (.not. associated(it)) return
    if (allocated(it%r)) v = it%r(1:min(size(v), size(it%r)))
  end subroutine record_reals

  !> Item k's integer values (v's size of them, C order).
  subroutine record_ints(h, k, v)
    integer, intent(in) :: h, k
    integer, intent(out) :: v(:)
    type(rec_item_t), pointer :: it
    v = 0
    it => item_at(h, k)
    if (.not. associated(it)) return
    if (allocated(it%i)) v = it%i(1:min(size(v), size(it%i)))
  end subroutine record_ints

  !> Item k's integer attribute (0 where it has none).
  integer(i8) function record_long(h, k) result(v)
    integer, intent(in) :: h, k
    type(rec_item_t), pointer :: it
    v = 0
    it => item_at(h, k)
    if (.not. associated(it)) return
    if (allocated(it%l)) v = it%l(1)
  end function record_long

  !> String j of item k ('' if none).
  function record_string(h, k, j) result(s)
    integer, intent(in) :: h, k, j
    character(:), allocatable :: s
    type(rec_item_t), pointer :: it
    s = ''
    it => item_at(h, k)
    if (.not. associated(it)) return
    if (.not. allocated(it%s)) return
    if (j >= 1 .and. j <= size(it%s)) s = trim(it%s(j))
  end function record_string

  !> Console line j of record h: its stream (REC_STDOUT, REC_STDERR; 0: no such line) and text.
  subroutine record_line(h, j, stream, text)
    integer, intent(in) :: h, j
    integer, intent(out) :: stream
    character(:), allocatable, intent(out) :: text
    type(record_t), pointer :: r
    stream = 0
    text = ''
    r => record_at(h)
    if (.not. associated(r)) return
    if (j < 1 .or. j > r%n_lines) return
    stream = r%lines(j)%stream
    text = r%lines(j)%text
  end subroutine record_line
end module tubes_record
