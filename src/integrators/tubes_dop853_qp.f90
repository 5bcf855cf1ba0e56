!> DOP853 in quad precision (real128) for reference solutions: Hairer's 8(5,3) pair with the same
!> step-size control as tubes_dop853, on a vector field written in real128 (qp_field_t). The
!> coefficients are tubes_dop853_tableau's: its 30-digit decimal strings are real128 literals
!> there (relative rounding <= 1e-29, far below the ~1e-25 the references aim at), rounded for
!> the double-precision stepper. The order conditions are checked in qp in tests/test_reference.f90). No dense output: a reference is
!> the state at the end time. Cost and accuracy: docs/events.md ("Reference solutions").
module tubes_dop853_qp
  use tubes_kinds, only: qp, i8
  use tubes_dop853_tableau, only: qp_tableau_a, qp_tableau_e3, qp_tableau_e5, qp_nodes, NSX
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL, TUBES_EMAXSTEPS
  implicit none
  private

  integer, parameter, public :: QP_NS = 12    !! stages of the 8th-order step
  integer, parameter :: NS = QP_NS
  real(qp), parameter :: SAFETY = 0.9_qp, FAC_MIN = 0.333_qp, FAC_MAX = 6.0_qp

  !> A vector field dx/dt = f(t, x) in real128.
  type, abstract, public :: qp_field_t
  contains
    procedure(qp_dim_i), deferred :: dim     !! state dimension
    procedure(qp_eval_i), deferred :: eval   !! dx/dt = f(t, x)
  end type qp_field_t

  abstract interface
    pure integer function qp_dim_i(self)
      import :: qp_field_t
      class(qp_field_t), intent(in) :: self
    end function qp_dim_i
    pure subroutine qp_eval_i(self, t, x, dxdt, stat)
      import :: qp_field_t, qp
      class(qp_field_t), intent(in) :: self
      real(qp), intent(in) :: t, x(:)
      real(qp), intent(out) :: dxdt(:)
      integer, intent(out) :: stat     !! 0 ok, > 0 retry with a smaller step, < 0 fatal
    end subroutine qp_eval_i
  end interface

  public :: dop853_qp_solve, qp_tableau_a, qp_tableau_e3, qp_tableau_e5, qp_nodes

contains


  !> Integrate x from t0 to t_end (either direction) with adaptive DOP853 in real128:
  !> error norm err = h err5^2/sqrt((err5^2 + 0.01 err3^2) n) on the scale
  !> sc_i = atol + rtol max(|x_i|, |x_new,i|), accepted when err <= 1, new step
  !> h min(6, max(1/3, 0.9 err^(-1/8))), no increase right after a rejection (as dop853.f and
  !> tubes_dop853). On failure x is the state at t_reached, the last accepted step.
  subroutine dop853_qp_solve(f, t0, x, t_end, rtol, atol, stat, t_reached, nsteps, nfev, &
                             nrejected, max_steps)
    class(qp_field_t), intent(in) :: f
    real(qp), intent(in) :: t0                      !! initial time
    real(qp), intent(inout) :: x(:)                 !! state at t0; on return at t_reached
    real(qp), intent(in) :: t_end                   !! final time
    real(qp), intent(in) :: rtol, atol              !! tolerances (> 0)
    integer, intent(out) :: stat                    !! TUBES_OK or a failure code
    real(qp), intent(out), optional :: t_reached    !! t_end, or the last accepted time
    integer(i8), intent(out), optional :: nsteps    !! accepted steps
    integer(i8), intent(out), optional :: nfev      !! right-hand-side evaluations
    integer(i8), intent(out), optional :: nrejected !! rejected steps
    integer(i8), intent(in), optional :: max_steps  !! step budget (default 10^8)
    real(qp) :: a(NSX, NSX), e3(NS + 1), e5(NS + 1), k(size(x), NS + 1), cq(NSX)
    real(qp) :: t, dir, h, hmin, err, err3, err5, den, fac, xnew(size(x)), sk(size(x))
    real(qp) :: xs(size(x)), acc(size(x))
    integer(i8) :: ns_acc, nf, nrej, budget
    integer :: i, j, n, fs, nnz(NS + 1), jnz(NS + 1, NS), nz3, nz5, j3(NS + 1), j5(NS + 1)
    logical :: last, reject_prev
    n = size(x)
    t = t0
    ns_acc = 0; nf = 0; nrej = 0
    budget = 100000000_i8
    if (present(max_steps)) budget = max_steps
    stat = TUBES_OK
    if (n /= f%dim() .or. .not. (rtol > 0 .and. atol > 0)) then
      stat = TUBES_EINPUT
      call report()
      return
    end if
    a = qp_tableau_a()
    cq = qp_nodes()
    e3 = qp_tableau_e3()
    e5 = qp_tableau_e5()
    ! nonzero pattern of a and of the error weights: software real128 arithmetic is the
    ! whole cost, and a quarter of the products in a full matmul are by zero
    do i = 2, NS + 1
      nnz(i) = 0
      do j = 1, i - 1
        if (a(i, j) /= 0) then
          nnz(i) = nnz(i) + 1
          jnz(i, nnz(i)) = j
        end if
      end do
    end do
    nz3 = 0; nz5 = 0
    do j = 1, NS + 1
      if (e3(j) /= 0) then
        nz3 = nz3 + 1
        j3(nz3) = j
      end if
      if (e5(j) /= 0) then
        nz5 = nz5 + 1
        j5(nz5) = j
      end if
    end do
    dir = sign(1.0_qp, t_end - t0)
    call f%eval(t, x, k(:, 1), fs)
    nf = nf + 1
    if (fs /= 0) then
      stat = TUBES_EMODEL
      call report()
      return
    end if
    if (t_end == t0) then
      call report()
      return
    end if
    call initial_step(h)
    reject_prev = .false.
    do while (dir*(t_end - t) > 0)
      if (ns_acc >= budget) then
        stat = TUBES_EMAXSTEPS
        exit
      end if
      hmin = 16*epsilon(1.0_qp)*max(abs(t), abs(t_end) - abs(t_end - t), tiny(1.0_qp))
      last = h*(1 + 64*epsilon(1.0_qp)) >= abs(t_end - t)
      if (last) h = abs(t_end - t)
      if (h < hmin .and. .not. last) then
        stat = TUBES_ESTEP
        exit
      end if
      do i = 2, NS
        call combine(i, xs)
        call f%eval(t + dir*cq(i)*h, xs, k(:, i), fs)
        nf = nf + 1
        if (fs /= 0) exit
      end do
      if (fs == 0) then
        call combine(NS + 1, xnew)
        call f%eval(t + dir*h, xnew, k(:, NS + 1), fs)
        nf = nf + 1
      end if
      if (fs < 0) then
        stat = TUBES_EMODEL
        exit
      end if
      if (fs > 0) then
        h = h/4
        nrej = nrej + 1
        reject_prev = .true.
        cycle
      end if
      sk = atol + rtol*max(abs(x), abs(xnew))
      acc = 0
      do j = 1, nz5
        acc = acc + e5(j5(j))*k(:, j5(j))
      end do
      err5 = sum((acc/sk)**2)
      acc = 0
      do j = 1, nz3
        acc = acc + e3(j3(j))*k(:, j3(j))
      end do
      err3 = sum((acc/sk)**2)
      den = err5 + 0.01_qp*err3
      err = 0
      if (den > 0) err = h*err5/sqrt(den*n)
      if (.not. (err <= huge(1.0_qp))) then
        stat = TUBES_EMODEL
        exit
      end if
      if (err > 1) then
        nrej = nrej + 1
        reject_prev = .true.
        h = h*max(FAC_MIN, SAFETY*err**(-1.0_qp/8))
        cycle
      end if
      fac = FAC_MAX
      if (err > 0) fac = min(FAC_MAX, max(FAC_MIN, SAFETY*err**(-1.0_qp/8)))
      if (reject_prev) fac = min(1.0_qp, fac)
      reject_prev = .false.
      x = xnew
      if (last) then
        t = t_end
      else
        t = t + dir*h
      end if
      k(:, 1) = k(:, NS + 1)   ! FSAL
      ns_acc = ns_acc + 1
      h = h*fac
    end do
    call report()

  contains

    !> y = x + h sum_j a(i, j) k(:, j) over the nonzero a(i, j).
    subroutine combine(i, y)
      integer, intent(in) :: i
      real(qp), intent(out) :: y(:)
      integer :: jj
      acc = 0
      do jj = 1, nnz(i)
        acc = acc + a(i, jnz(i, jj))*k(:, jnz(i, jj))
      end do
      y = x + (dir*h)*acc
    end subroutine combine

    subroutine report()
      if (present(t_reached)) t_reached = t
      if (present(nsteps)) nsteps = ns_acc
      if (present(nfev)) nfev = nf
      if (present(nrejected)) nrejected = nrej
    end subroutine report

    !> Hairer's starting step (Solving ODEs I, II.4), as tubes_dop853.
    subroutine initial_step(h0)
      real(qp), intent(out) :: h0
      real(qp) :: d0, d1, d2, h1, x1(size(x)), f1(size(x))
      integer :: fs1
      sk = atol + rtol*abs(x)
      d0 = sqrt(sum((x/sk)**2)/n)
      d1 = sqrt(sum((k(:, 1)/sk)**2)/n)
      if (d0 < 1.0e-5_qp .or. d1 < 1.0e-5_qp) then
        h0 = 1.0e-6_qp
      else
        h0 = 0.01_qp*d0/d1
      end if
      h0 = min(h0, abs(t_end - t0))
      x1 = x + dir*h0*k(:, 1)
      call f%eval(t + dir*h0, x1, f1, fs1)
      nf = nf + 1
      if (fs1 /= 0) return   ! keep the cautious guess
      d2 = sqrt(sum(((f1 - k(:, 1))/sk)**2)/n)/h0
      if (max(d1, d2) <= 1.0e-15_qp) then
        h1 = max(1.0e-6_qp, h0*1.0e-3_qp)
      else
        h1 = (0.01_qp/max(d1, d2))**(1.0_qp/8)
      end if
      h0 = min(100*h0, h1)
    end subroutine initial_step
  end subroutine dop853_qp_solve

end module tubes_dop853_qp
