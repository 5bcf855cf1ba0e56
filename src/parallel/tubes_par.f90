!> Work sharing over MPI ranks (docs/cluster.md).
!>
!> The items 1..n of an ensemble (tube seeds, Monte Carlo samples, Poincare seeds, tracks,
!> multiple-shooting segments) are dealt out cyclically: rank r computes the items k with
!> mod(k - 1, nranks) == r (OpenMP threads share them inside the rank), then par_share gathers
!> every item's result to every rank, in index order. Each item is computed by the same code
!> from the same inputs whichever rank owns it, so the gathered result is the serial one bit
!> for bit, for any number of ranks and threads. The inputs of a distributed loop that come
!> from replicated serial work (the orbit, the sample points) are broadcast from rank 0 first
!> (par_bcast), so that ranks agree even if their libraries' kernels differ in the last bit.
!>
!> Compiled with -DTUBES_MPI (make MPI=1) these call MPI on MPI_COMM_WORLD; otherwise, and
!> whenever MPI is not initialised (the Python extension, the C API's test program), every
!> procedure is the one-rank identity. MPI calls are made only outside OpenMP parallel regions
!> (MPI_THREAD_FUNNELED). No module state: the rank and size are queried from MPI.
module tubes_par
#ifdef TUBES_MPI
  use mpi_f08, only: MPI_Initialized, MPI_Finalized, MPI_Comm_size, MPI_Comm_rank, MPI_Allgatherv, &
                     MPI_Bcast, MPI_COMM_WORLD, MPI_DOUBLE_PRECISION, MPI_INTEGER
#endif
  use tubes_kinds, only: wp
  implicit none
  private

  !> The calling rank's share of a loop: item k is computed here when mine(k).
  type, public :: par_t
    integer :: rank = 0      !! this rank, 0-based
    integer :: nranks = 1    !! number of ranks
  contains
    procedure :: mine => par_mine
  end type par_t

  public :: par_here, par_share, par_bcast, par_fault_item, par_active

  !> Gather the items (the last dimension) computed by their owners to every rank.
  interface par_share
    module procedure share_r1, share_r2, share_r3, share_i1, share_i2, share_l1
  end interface par_share

  !> Broadcast from rank 0.
  interface par_bcast
    module procedure bcast_r0, bcast_r1, bcast_r2
  end interface par_bcast
contains
  !> True when running on more than one rank (MPI build, MPI initialised, size > 1).
  logical function par_active(p)
    type(par_t), intent(in), optional :: p   !! the group (default: all ranks)
    type(par_t) :: q
    q = group_of(p)
    par_active = q%nranks > 1
  end function par_active

  !> The group p if given, else all ranks (par_here()).
  function group_of(p) result(q)
    type(par_t), intent(in), optional :: p
    type(par_t) :: q
    if (present(p)) then
      q = p
    else
      q = par_here()
    end if
  end function group_of

  !> The calling rank and the number of ranks (0 and 1 without MPI, or with local = .true.:
  !> the caller has already dealt out a coarser level, e.g. energies, and this rank works alone).
  function par_here(local) result(p)
    logical, intent(in), optional :: local
    type(par_t) :: p
#ifdef TUBES_MPI
    logical :: up, down
    p%rank = 0
    p%nranks = 1
    if (present(local)) then
      if (local) return
    end if
    call MPI_Initialized(up)
    call MPI_Finalized(down)
    if (up .and. .not. down) then
      call MPI_Comm_rank(MPI_COMM_WORLD, p%rank)
      call MPI_Comm_size(MPI_COMM_WORLD, p%nranks)
      return
    end if
#endif
    p%rank = 0
    p%nranks = 1
  end function par_here

  !> Whether item k (1-based) is computed on this rank.
  elemental logical function par_mine(self, k)
    class(par_t), intent(in) :: self
    integer, intent(in) :: k     !! item index, 1-based
    par_mine = mod(k - 1, self%nranks) == self%rank
  end function par_mine

#ifdef TUBES_MPI
  !> Number of items of 1..n owned by rank r.
  pure integer function n_owned(n, r, np)
    integer, intent(in) :: n, r, np
    n_owned = max(0, (n - r + np - 1)/np)
  end function n_owned

  !> Allgatherv's layout: rank r's count of values (w per item it owns) and its offset.
  pure subroutine layout(w, n, np, counts, displs)
    integer, intent(in) :: w, n, np
    integer, intent(out) :: counts(0:np - 1), displs(0:np - 1)
    integer :: r
    do r = 0, np - 1
      counts(r) = w*n_owned(n, r, np)
    end do
    displs(0) = 0
    do r = 1, np - 1
      displs(r) = displs(r - 1) + counts(r - 1)
    end do
  end subroutine layout

#endif

  !> The core of par_share for reals: buf holds n items of w values each.
  subroutine share_dp(buf, w, n, p)
    integer, intent(in) :: w     !! values per item
    integer, intent(in) :: n     !! items
    real(wp), intent(inout) :: buf(w, n)
    type(par_t), intent(in) :: p
#ifdef TUBES_MPI
    real(wp), allocatable :: send(:, :), recv(:)
    integer :: counts(0:p%nranks - 1), displs(0:p%nranks - 1)
    integer :: r, m
    if (p%nranks == 1 .or. n == 0 .or. w == 0) return
    call layout(w, n, p%nranks, counts, displs)
    send = buf(:, p%rank + 1:n:p%nranks)
    allocate (recv(sum(counts)))
    call MPI_Allgatherv(send, size(send), MPI_DOUBLE_PRECISION, recv, counts, displs, &
                        MPI_DOUBLE_PRECISION, MPI_COMM_WORLD)
    do r = 0, p%nranks - 1
      m = n_owned(n, r, p%nranks)
      if (m > 0) buf(:, r + 1:n:p%nranks) = reshape(recv(displs(r) + 1:displs(r) + counts(r)), [w, m])
    end do
#endif
  end subroutine share_dp

  !> The core of par_share for integers: share_dp on their values as doubles (exact: every
  !> default integer is a double).
  subroutine share_int(buf, w, n, p)
    integer, intent(in) :: w, n
    integer, intent(inout) :: buf(w, n)
    type(par_t), intent(in) :: p
    real(wp), allocatable :: d(:, :)
    if (p%nranks == 1 .or. n == 0 .or. w == 0) return
    d = real(buf, wp)
    call share_dp(d, w, n, p)
    buf = nint(d)
  end subroutine share_int

  subroutine share_r1(a, p)
    real(wp), intent(inout), contiguous :: a(:)       !! one value per item
    type(par_t), intent(in), optional :: p   !! the group that computed the items (default: all ranks)
    call share_dp(a, 1, size(a), group_of(p))
  end subroutine share_r1

  subroutine share_r2(a, p)
    real(wp), intent(inout), contiguous :: a(:, :)    !! items along the second dimension
    type(par_t), intent(in), optional :: p   !! the group that computed the items (default: all ranks)
    call share_dp(a, size(a, 1), size(a, 2), group_of(p))
  end subroutine share_r2

  subroutine share_r3(a, p)
    real(wp), intent(inout), contiguous :: a(:, :, :) !! items along the third dimension
    type(par_t), intent(in), optional :: p   !! the group that computed the items (default: all ranks)
    call share_dp(a, size(a, 1)*size(a, 2), size(a, 3), group_of(p))
  end subroutine share_r3

  subroutine share_i1(a, p)
    integer, intent(inout), contiguous :: a(:)
    type(par_t), intent(in), optional :: p   !! the group that computed the items (default: all ranks)
    call share_int(a, 1, size(a), group_of(p))
  end subroutine share_i1

  subroutine share_i2(a, p)
    integer, intent(inout), contiguous :: a(:, :)     !! items along the second dimension
    type(par_t), intent(in), optional :: p   !! the group that computed the items (default: all ranks)
    call share_int(a, size(a, 1), size(a, 2), group_of(p))
  end subroutine share_i2

  subroutine share_l1(a, p)
    logical, intent(inout), contiguous :: a(:)
    type(par_t), intent(in), optional :: p
    integer :: b(size(a))
    b = merge(1, 0, a)
    call share_int(b, 1, size(b), group_of(p))
    a = b /= 0
  end subroutine share_l1

  subroutine bcast_dp(buf, n, p)
    integer, intent(in) :: n
    real(wp), intent(inout) :: buf(n)
    type(par_t), intent(in), optional :: p
#ifdef TUBES_MPI
    if (.not. par_active(p)) return
    call MPI_Bcast(buf, n, MPI_DOUBLE_PRECISION, 0, MPI_COMM_WORLD)
#endif
  end subroutine bcast_dp

  subroutine bcast_r0(a, p)
    real(wp), intent(inout) :: a
    type(par_t), intent(in), optional :: p   !! the group (default: all ranks); one rank: no-op
    real(wp) :: b(1)
    b(1) = a
    call bcast_dp(b, 1, p)
    a = b(1)
  end subroutine bcast_r0

  subroutine bcast_r1(a, p)
    real(wp), intent(inout), contiguous :: a(:)
    type(par_t), intent(in), optional :: p
    call bcast_dp(a, size(a), p)
  end subroutine bcast_r1

  subroutine bcast_r2(a, p)
    real(wp), intent(inout), contiguous :: a(:, :)
    type(par_t), intent(in), optional :: p
    call bcast_dp(a, size(a), p)
  end subroutine bcast_r2

  !> Fault injection for the tests (docs/development.md): with the environment variable
  !> TUBES_FAULT=loop:k (loop one of seed, sample, map, track, segment), item k of every such
  !> loop fails with TUBES_EFAULT. Returns k, or 0 when no fault is set for this loop.
  integer function par_fault_item(loop)
    character(*), intent(in) :: loop
    character(64) :: v
    integer :: n, st, c, k
    par_fault_item = 0
    call get_environment_variable('TUBES_FAULT', v, n, st)
    if (st /= 0 .or. n == 0) return
    c = index(v, ':')
    if (c < 2) return
    if (v(1:c - 1) /= loop) return
    read (v(c + 1:n), *, iostat=st) k
    if (st == 0 .and. k > 0) par_fault_item = k
  end function par_fault_item
end module tubes_par
