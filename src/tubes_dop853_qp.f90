!> DOP853 in quad precision (real128) for reference solutions: Hairer's 8(5,3) pair with the same
!> step-size control as tubes_dop853, on a vector field written in real128 (qp_field_t). The
!> coefficients are the 30-digit decimal strings of tubes_dop853_tableau read as real128
!> literals (relative rounding <= 1e-29, far below the ~1e-25 the references aim at; the order
!> conditions are checked in qp in tests/test_reference.f90). No dense output: a reference is
!> the state at the end time. Cost and accuracy: docs/events.md ("Reference solutions").
module tubes_dop853_qp
  use tubes_kinds, only: qp, i8
  use tubes_status, only: TUBES_OK, TUBES_EINPUT, TUBES_ESTEP, TUBES_EMODEL, TUBES_EMAXSTEPS
  implicit none
  private

  integer, parameter, public :: QP_NS = 12    !! stages of the 8th-order step
  integer, parameter :: NS = QP_NS
  integer, parameter :: NSX = 16              ! stages including the 3 dense-output stages
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

  !> Nodes c_i (the 30-digit strings of tubes_dop853_tableau).
  real(qp), parameter :: CQ(NSX) = [ &
    0.0e0_qp,&
    0.526001519587677318785587544488e-1_qp,&
    0.789002279381515978178381316732e-1_qp,&
    0.118350341907227396726757197510e0_qp,&
    0.281649658092772603273242802490e0_qp,&
    0.333333333333333333333333333333e0_qp,&
    0.25e0_qp,&
    0.307692307692307692307692307692e0_qp,&
    0.651282051282051282051282051282e0_qp,&
    0.6e0_qp,&
    0.857142857142857142857142857142e0_qp,&
    1.0e0_qp,&
    1.0e0_qp,&
    0.1e0_qp,&
    0.2e0_qp,&
    0.777777777777777777777777777778e0_qp]

  public :: dop853_qp_solve, qp_tableau_a, qp_tableau_e3, qp_tableau_e5, qp_nodes

contains

  !> The nodes c_i, i = 1..16 (for order-condition checks).
  pure function qp_nodes() result(c)
    real(qp) :: c(NSX)
    c = CQ
  end function qp_nodes

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
    real(qp) :: a(NSX, NSX), e3(NS + 1), e5(NS + 1), k(size(x), NS + 1)
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
        call f%eval(t + dir*CQ(i)*h, xs, k(:, i), fs)
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

  !> Runge-Kutta matrix a(i, j) in real128 (same strings as tubes_dop853_tableau).
  pure function qp_tableau_a() result(a)
    real(qp) :: a(NSX, NSX)
    a = 0
    a(2, 1) = 5.26001519587677318785587544488e-2_qp
    a(3, 1) = 1.97250569845378994544595329183e-2_qp
    a(3, 2) = 5.91751709536136983633785987549e-2_qp
    a(4, 1) = 2.95875854768068491816892993775e-2_qp
    a(4, 3) = 8.87627564304205475450678981324e-2_qp
    a(5, 1) = 2.41365134159266685502369798665e-1_qp
    a(5, 3) = -8.84549479328286085344864962717e-1_qp
    a(5, 4) = 9.24834003261792003115737966543e-1_qp
    a(6, 1) = 3.7037037037037037037037037037e-2_qp
    a(6, 4) = 1.70828608729473871279604482173e-1_qp
    a(6, 5) = 1.25467687566822425016691814123e-1_qp
    a(7, 1) = 3.7109375e-2_qp
    a(7, 4) = 1.70252211019544039314978060272e-1_qp
    a(7, 5) = 6.02165389804559606850219397283e-2_qp
    a(7, 6) = -1.7578125e-2_qp
    a(8, 1) = 3.70920001185047927108779319836e-2_qp
    a(8, 4) = 1.70383925712239993810214054705e-1_qp
    a(8, 5) = 1.07262030446373284651809199168e-1_qp
    a(8, 6) = -1.53194377486244017527936158236e-2_qp
    a(8, 7) = 8.27378916381402288758473766002e-3_qp
    a(9, 1) = 6.24110958716075717114429577812e-1_qp
    a(9, 4) = -3.36089262944694129406857109825e0_qp
    a(9, 5) = -8.68219346841726006818189891453e-1_qp
    a(9, 6) = 2.75920996994467083049415600797e1_qp
    a(9, 7) = 2.01540675504778934086186788979e1_qp
    a(9, 8) = -4.34898841810699588477366255144e1_qp
    a(10, 1) = 4.77662536438264365890433908527e-1_qp
    a(10, 4) = -2.48811461997166764192642586468e0_qp
    a(10, 5) = -5.90290826836842996371446475743e-1_qp
    a(10, 6) = 2.12300514481811942347288949897e1_qp
    a(10, 7) = 1.52792336328824235832596922938e1_qp
    a(10, 8) = -3.32882109689848629194453265587e1_qp
    a(10, 9) = -2.03312017085086261358222928593e-2_qp
    a(11, 1) = -9.3714243008598732571704021658e-1_qp
    a(11, 4) = 5.18637242884406370830023853209e0_qp
    a(11, 5) = 1.09143734899672957818500254654e0_qp
    a(11, 6) = -8.14978701074692612513997267357e0_qp
    a(11, 7) = -1.85200656599969598641566180701e1_qp
    a(11, 8) = 2.27394870993505042818970056734e1_qp
    a(11, 9) = 2.49360555267965238987089396762e0_qp
    a(11, 10) = -3.0467644718982195003823669022e0_qp
    a(12, 1) = 2.27331014751653820792359768449e0_qp
    a(12, 4) = -1.05344954667372501984066689879e1_qp
    a(12, 5) = -2.00087205822486249909675718444e0_qp
    a(12, 6) = -1.79589318631187989172765950534e1_qp
    a(12, 7) = 2.79488845294199600508499808837e1_qp
    a(12, 8) = -2.85899827713502369474065508674e0_qp
    a(12, 9) = -8.87285693353062954433549289258e0_qp
    a(12, 10) = 1.23605671757943030647266201528e1_qp
    a(12, 11) = 6.43392746015763530355970484046e-1_qp
    a(13, 1) = 5.42937341165687622380535766363e-2_qp
    a(13, 6) = 4.45031289275240888144113950566e0_qp
    a(13, 7) = 1.89151789931450038304281599044e0_qp
    a(13, 8) = -5.8012039600105847814672114227e0_qp
    a(13, 9) = 3.1116436695781989440891606237e-1_qp
    a(13, 10) = -1.52160949662516078556178806805e-1_qp
    a(13, 11) = 2.01365400804030348374776537501e-1_qp
    a(13, 12) = 4.47106157277725905176885569043e-2_qp
    a(14, 1) = 5.61675022830479523392909219681e-2_qp
    a(14, 7) = 2.53500210216624811088794765333e-1_qp
    a(14, 8) = -2.46239037470802489917441475441e-1_qp
    a(14, 9) = -1.24191423263816360469010140626e-1_qp
    a(14, 10) = 1.5329179827876569731206322685e-1_qp
    a(14, 11) = 8.20105229563468988491666602057e-3_qp
    a(14, 12) = 7.56789766054569976138603589584e-3_qp
    a(14, 13) = -8.298e-3_qp
    a(15, 1) = 3.18346481635021405060768473261e-2_qp
    a(15, 6) = 2.83009096723667755288322961402e-2_qp
    a(15, 7) = 5.35419883074385676223797384372e-2_qp
    a(15, 8) = -5.49237485713909884646569340306e-2_qp
    a(15, 11) = -1.08347328697249322858509316994e-4_qp
    a(15, 12) = 3.82571090835658412954920192323e-4_qp
    a(15, 13) = -3.40465008687404560802977114492e-4_qp
    a(15, 14) = 1.41312443674632500278074618366e-1_qp
    a(16, 1) = -4.28896301583791923408573538692e-1_qp
    a(16, 6) = -4.69762141536116384314449447206e0_qp
    a(16, 7) = 7.68342119606259904184240953878e0_qp
    a(16, 8) = 4.06898981839711007970213554331e0_qp
    a(16, 9) = 3.56727187455281109270669543021e-1_qp
    a(16, 13) = -1.39902416515901462129418009734e-3_qp
    a(16, 14) = 2.9475147891527723389556272149e0_qp
    a(16, 15) = -9.15095847217987001081870187138e0_qp
  end function qp_tableau_a
  !> Weights of the 3rd-order error estimator, 13 entries.
  pure function qp_tableau_e3() result(e)
    real(qp) :: e(NS + 1), a(NSX, NSX)
    a = qp_tableau_a()
    e = 0
    e(1:NS) = a(NS + 1, 1:NS)
    e(1) = e(1) - 0.244094488188976377952755905512e0_qp
    e(9) = e(9) - 0.733846688281611857341361741547e0_qp
    e(12) = e(12) - 0.220588235294117647058823529412e-1_qp
  end function qp_tableau_e3
  !> Weights of the 5th-order error estimator, 13 entries.
  pure function qp_tableau_e5() result(e)
    real(qp) :: e(NS + 1)
    e = 0
    e(1) = 0.1312004499419488073250102996e-1_qp
    e(6) = -0.1225156446376204440720569753e1_qp
    e(7) = -0.4957589496572501915214079952e0_qp
    e(8) = 0.1664377182454986536961530415e1_qp
    e(9) = -0.3503288487499736816886487290e0_qp
    e(10) = 0.3341791187130174790297318841e0_qp
    e(11) = 0.8192320648511571246570742613e-1_qp
    e(12) = -0.2235530786388629525884427845e-1_qp
  end function qp_tableau_e5
end module tubes_dop853_qp
