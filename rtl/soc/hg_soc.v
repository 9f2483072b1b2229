// SPDX-License-Identifier: Apache-2.0
// The hapgate SoC: a VexRiscv CPU (RV32IM, the PyPI package's VexRiscv_FullCfu.v, unmodified)
// that runs the firmware (dsp-fw/board/riscv) from block RAM, the float unit on its
// custom-function port, a UART to the PC, the machine timer, and the bridge that drives the
// FPGA's DSP bus pins, so that word w of the register file is the CPU's 32-bit word at
// 0x8001_0000 + 4w. The servo tick (the register file's irq) is the CPU's external interrupt
// line 0. Memory map and timing: rtl/soc/README.md.
`timescale 1ns / 1ps
`default_nettype none

module hg_soc #(
    parameter integer CLK_HZ        = 48_000_000,      // clock: a multiple of 1 MHz
    parameter integer BAUD          = 1_000_000,       // the UART's rate
    parameter integer RX_FIFO_LOG2  = 7,               // the UART's receive FIFO, log2 bytes (it
                                                       // holds what arrives during the tick handler)
    parameter integer RAM_LOG2      = 17,              // RAM bytes, log2 (17: 128 KiB; the
                                                       // linker script's SOC_RAM_BYTES)
    parameter         FW_FILE       = "hapgate-fw.hex", // the firmware image ($readmemh words)
    parameter integer BUS_ADDR_BITS = 8                // the DSP bus's word-address lines
) (
    input  wire                     clk,
    input  wire                     rst,
    input  wire                     uart_rx,
    output wire                     uart_tx,
    input  wire                     irq_tick,      // the register file's servo-tick interrupt
    // the DSP bus of hapgate_top, driven as its master
    output wire                     bus_ce_n,
    output wire                     bus_re_n,
    output wire                     bus_we_n,
    output wire [BUS_ADDR_BITS-1:0] bus_addr,
    output wire [31:0]              bus_wdata,
    input  wire [31:0]              bus_rdata,
    input  wire                     bus_ready
);
    localparam integer RAM_AW = RAM_LOG2 - 2;   // RAM word-address bits

    generate
        if (RAM_LOG2 < 10 || RAM_LOG2 > 22) begin : g_bad_ram
            hg_soc_RAM_LOG2_must_be_10_to_22 u_stop ();
        end
        if (BUS_ADDR_BITS < 6 || BUS_ADDR_BITS > 13) begin : g_bad_bus
            hg_soc_BUS_ADDR_BITS_must_be_6_to_13 u_stop ();
        end
    endgenerate

    // ---------------------------------------------------------------- CPU
    wire        i_cyc, i_stb, i_we;
    wire [29:0] i_adr;
    wire [31:0] i_dat_w;
    wire [3:0]  i_sel;
    wire [2:0]  i_cti;
    wire [1:0]  i_bte;
    reg         i_ack, i_err;
    wire [31:0] i_dat_r;

    wire        d_cyc, d_stb, d_we;
    wire [29:0] d_adr;
    wire [31:0] d_dat_w;
    wire [3:0]  d_sel;
    wire [2:0]  d_cti;
    wire [1:0]  d_bte;
    wire        d_ack, d_err;
    reg  [31:0] d_dat_r;
    wire        timer_irq;

    // the custom-function port (CUSTOM_0 instructions: function id {funct7, funct3})
    wire        cfu_cmd_valid, cfu_cmd_ready, cfu_rsp_valid, cfu_rsp_ready;
    wire [9:0]  cfu_function_id;
    wire [31:0] cfu_in0, cfu_in1, cfu_out;

    VexRiscv u_cpu (
        .clk(clk), .reset(rst),
        .externalResetVector(32'h0000_0000),
        .timerInterrupt(timer_irq), .softwareInterrupt(1'b0),
        .externalInterruptArray({31'd0, irq_tick}),
        .CfuPlugin_bus_cmd_valid(cfu_cmd_valid), .CfuPlugin_bus_cmd_ready(cfu_cmd_ready),
        .CfuPlugin_bus_cmd_payload_function_id(cfu_function_id),
        .CfuPlugin_bus_cmd_payload_inputs_0(cfu_in0), .CfuPlugin_bus_cmd_payload_inputs_1(cfu_in1),
        .CfuPlugin_bus_rsp_valid(cfu_rsp_valid), .CfuPlugin_bus_rsp_ready(cfu_rsp_ready),
        .CfuPlugin_bus_rsp_payload_outputs_0(cfu_out),
        .iBusWishbone_CYC(i_cyc), .iBusWishbone_STB(i_stb), .iBusWishbone_ACK(i_ack),
        .iBusWishbone_WE(i_we), .iBusWishbone_ADR(i_adr), .iBusWishbone_DAT_MISO(i_dat_r),
        .iBusWishbone_DAT_MOSI(i_dat_w), .iBusWishbone_SEL(i_sel), .iBusWishbone_ERR(i_err),
        .iBusWishbone_CTI(i_cti), .iBusWishbone_BTE(i_bte),
        .dBusWishbone_CYC(d_cyc), .dBusWishbone_STB(d_stb), .dBusWishbone_ACK(d_ack),
        .dBusWishbone_WE(d_we), .dBusWishbone_ADR(d_adr), .dBusWishbone_DAT_MISO(d_dat_r),
        .dBusWishbone_DAT_MOSI(d_dat_w), .dBusWishbone_SEL(d_sel), .dBusWishbone_ERR(d_err),
        .dBusWishbone_CTI(d_cti), .dBusWishbone_BTE(d_bte)
    );
    // the fetch only reads whole words; the buses' burst hints are not needed (every beat is
    // a single access here)
    wire unused_cpu = &{1'b0, i_we, i_dat_w, i_sel, i_cti, i_bte, d_cti, d_bte};

    // ---------------------------------------------------------------- float unit
    // single-precision add, subtract, multiply, divide (the firmware's __addsf3 ... __divsf3);
    // the CPU enables the port with bit 31 of CSR 0xBC0 (dsp-fw/board/riscv/start.S)
    hg_fpu_cfu u_fpu (
        .clk(clk), .rst(rst),
        .cmd_valid(cfu_cmd_valid), .cmd_ready(cfu_cmd_ready), .cmd_function_id(cfu_function_id),
        .cmd_inputs_0(cfu_in0), .cmd_inputs_1(cfu_in1),
        .rsp_valid(cfu_rsp_valid), .rsp_ready(cfu_rsp_ready), .rsp_outputs_0(cfu_out)
    );

    // ---------------------------------------------------------------- address decode
    // Wishbone classic: a master holds its address until ACK or ERR. Each bus turns its strobe
    // into one request clock (busy until the answer); the answer's slave is decoded from the
    // address it still holds.
    wire i_ram = (i_adr[29:RAM_AW] == {(30 - RAM_AW){1'b0}});
    wire d_ram = (d_adr[29:RAM_AW] == {(30 - RAM_AW){1'b0}});
    // I/O (byte address bit 31): UART 0x8000_0000, timer 0x8000_1000, registers 0x8001_0000
    wire d_uart  = (d_adr[29:10] == 20'h80000) && (d_adr[9:2] == 8'd0);
    wire d_timer = (d_adr[29:10] == 20'h80001) && (d_adr[9:2] == 8'd0);
    wire d_regs  = (d_adr[29:14] == 16'h8001) &&
                   (d_adr[13:BUS_ADDR_BITS] == {(14 - BUS_ADDR_BITS){1'b0}});
    reg  i_busy, d_busy;
    wire i_req = i_cyc & i_stb & ~i_busy;
    wire d_req = d_cyc & d_stb & ~d_busy;

    // ---------------------------------------------------------------- RAM
    wire [31:0] ram_d_rdata;
    reg         ram_d_ack;
    hg_soc_ram #(.ADDR_BITS(RAM_AW), .INIT_FILE(FW_FILE)) u_ram (
        .clk(clk),
        .a_en(i_req & i_ram), .a_addr(i_adr[RAM_AW-1:0]), .a_rdata(i_dat_r),
        .b_en(d_req & d_ram), .b_we((d_req & d_ram & d_we) ? d_sel : 4'b0000),
        .b_addr(d_adr[RAM_AW-1:0]), .b_wdata(d_dat_w), .b_rdata(ram_d_rdata)
    );

    always @(posedge clk) begin
        if (rst) begin
            i_busy    <= 1'b0;
            i_ack     <= 1'b0;
            i_err     <= 1'b0;
            d_busy    <= 1'b0;
            ram_d_ack <= 1'b0;
        end else begin
            i_ack     <= i_req & i_ram;
            i_err     <= i_req & ~i_ram;   // no code outside the RAM
            i_busy    <= i_req | (i_busy & ~(i_ack | i_err));
            ram_d_ack <= d_req & d_ram;
            d_busy    <= d_req | (d_busy & ~(d_ack | d_err));
        end
    end

    // ---------------------------------------------------------------- UART and timer
    wire [31:0] uart_rdata, timer_rdata;
    reg         io_ack, bad_err;
    hg_uart #(.CLK_HZ(CLK_HZ), .BAUD(BAUD), .RX_FIFO_LOG2(RX_FIFO_LOG2)) u_uart (
        .clk(clk), .rst(rst), .s_req(d_req & d_uart), .s_we(d_we), .s_addr(d_adr[1:0]),
        .s_wdata(d_dat_w), .s_rdata(uart_rdata), .rx(uart_rx), .tx(uart_tx)
    );
    hg_mtimer #(.CLK_HZ(CLK_HZ)) u_timer (
        .clk(clk), .rst(rst), .s_req(d_req & d_timer), .s_we(d_we), .s_addr(d_adr[1:0]),
        .s_wdata(d_dat_w), .s_rdata(timer_rdata), .irq(timer_irq)
    );

    // ---------------------------------------------------------------- register file bridge
    // Only whole-word accesses reach the register file; a narrower write is a bus error.
    wire        regs_ack, regs_err;
    wire [31:0] regs_rdata;
    wire        regs_ok = ~d_we | (d_sel == 4'b1111);
    hg_emif_master #(.ADDR_BITS(BUS_ADDR_BITS)) u_bridge (
        .clk(clk), .rst(rst),
        .s_req(d_req & d_regs & regs_ok), .s_we(d_we), .s_addr(d_adr[BUS_ADDR_BITS-1:0]),
        .s_wdata(d_dat_w), .s_rdata(regs_rdata), .s_ack(regs_ack), .s_err(regs_err),
        .bus_ce_n(bus_ce_n), .bus_re_n(bus_re_n), .bus_we_n(bus_we_n), .bus_addr(bus_addr),
        .bus_wdata(bus_wdata), .bus_rdata(bus_rdata), .bus_ready(bus_ready)
    );

    wire d_unmapped = ~(d_ram | d_uart | d_timer | (d_regs & regs_ok));
    always @(posedge clk) begin
        if (rst) begin
            io_ack  <= 1'b0;
            bad_err <= 1'b0;
        end else begin
            io_ack  <= d_req & (d_uart | d_timer);
            bad_err <= d_req & d_unmapped;
        end
    end

    assign d_ack = ram_d_ack | io_ack | regs_ack;
    assign d_err = bad_err | regs_err;
    always @(*) begin
        if (d_ram)
            d_dat_r = ram_d_rdata;
        else if (d_uart)
            d_dat_r = uart_rdata;
        else if (d_timer)
            d_dat_r = timer_rdata;
        else
            d_dat_r = regs_rdata;
    end
endmodule

`default_nettype wire
